"""Issue 31: the CPU wake-latency hold is on by default only where the node is the robot's real-time process.

`spine-node --motors can` holds every CPU's wake-up at 0 us by default (docs/performance.md); the simulated
backends (`lcm`, `inprocess`) run beside a simulator on a shared machine and hold nothing unless asked.
"""

from __future__ import annotations

import pytest

from sparc_quad.cli import build_parser
from sparc_quad.cli.spine_node import wake_latency
from spine_module.node.realtime import WAKE_LATENCY_DEFAULT_US


@pytest.mark.parametrize("argv,expected", [
    (["--motors", "can"], WAKE_LATENCY_DEFAULT_US),
    (["--motors", "lcm"], None),
    (["--motors", "inprocess"], None),
    ([], None),  # the default backend is lcm
    (["--motors", "lcm", "--wake-latency-us", "20"], 20),
    (["--motors", "can", "--wake-latency-us", "off"], None),
])
def test_wake_latency_default_follows_the_backend(argv, expected):
    args = build_parser().parse_args(["spine-node", *argv])
    assert wake_latency(args) == expected
