"""Registry entry for `--motors lcm` (see `registry`)."""

from __future__ import annotations

from spine_module.buses.lcm import LcmMotorBus


def make_bus(*, lc=None, url: str = "", spin_s: float = 0.0) -> LcmMotorBus:
    """Motors over LCM at `url` (LCM's default if empty), sharing the node's LCM instance `lc` if given;
    `spin_s`: poll this long before a lockstep wait blocks (see `lcm.handle`)."""
    return LcmMotorBus(url=url, lc=lc, spin_s=spin_s)
