"""Registry entry for `--motors inprocess`: the node and the pybullet bench spine in one process.

The robot end of the link is driven by the caller (`sparc_quad.robot_side`); from the command line
`spine-node --motors inprocess` runs the bench robot in the same process (see `sparc_quad.cli.spine_node`).
"""

from __future__ import annotations

from spine_module.buses.inprocess import InProcessBus, InProcessLink


def make_bus(*, lc=None, link: InProcessLink | None = None) -> InProcessBus:
    """The node's end of `link` (a new link if None); `lc` is not used."""
    return InProcessBus(link if link is not None else InProcessLink())
