"""Registry entry for `--motors lcm` (see `registry`)."""

from __future__ import annotations

from spine_module.buses.lcm import LcmMotorBus


def make_bus(*, lc=None, url: str = "") -> LcmMotorBus:
    """Motors over LCM at `url` (LCM's default if empty), sharing the node's LCM instance `lc` if given."""
    return LcmMotorBus(url=url, lc=lc)
