"""Registry entry for `--motors lcm` (see `registry`)."""

from __future__ import annotations

import argparse

from spine_module.buses.lcm import LcmMotorBus


def make_bus(args: argparse.Namespace, lc=None) -> LcmMotorBus:
    return LcmMotorBus(url=getattr(args, "lcm_url", ""), lc=lc)
