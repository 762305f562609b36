"""Issue 31, "one node per robot": two nodes on one LCM URL both commanded the motors, with the same
heartbeat sender name, so the robot could not see that one died.

Each node now draws a random instance id that its heartbeats carry. On one memq:// URL (one LCM instance
shared by two nodes in this process): a node about to start hears the running one and says who
(`listen_for_nodes`, spine-node then exits 2); two running nodes each latch NODE_CONFLICT (motors stopped)
on the other's first heartbeat, and stay latched through a reset.
"""

from __future__ import annotations

import lcm
import numpy as np

from spine_module.buses.inprocess import InProcessBus, InProcessLink
from spine_module.messages import Fault, Heartbeat, Mode, SpineCommand, channels, codec
from spine_module.node import Controllers, LcmNodeIO, NodeConfig, SpineNode
from spine_module.safety import SafetyConfig
from tests.node_harness import FakeController


def _node(lc: lcm.LCM) -> SpineNode:
    ctrl = Controllers(impedance=FakeController(), pd=FakeController())
    return SpineNode(ctrl, InProcessBus(InProcessLink()), LcmNodeIO(lc),
                     NodeConfig(safety=SafetyConfig(heartbeat_required=False)))


def test_heartbeats_carry_distinct_instances():
    lc = lcm.LCM("memq://")
    a, b = _node(lc), _node(lc)
    assert a.cfg.instance != b.cfg.instance and a.cfg.instance and b.cfg.instance
    hb = codec.decode_heartbeat(codec.encode_heartbeat(Heartbeat("spine-node", instance=a.cfg.instance)))
    assert hb.instance == a.cfg.instance


def test_a_starting_node_hears_a_running_one():
    lc = lcm.LCM("memq://")
    running = _node(lc)
    running.tick(0.0, None)  # publishes its first heartbeat
    newcomer = LcmNodeIO(lc)
    peers = newcomer.listen_for_nodes(0.05)
    assert peers == {running.cfg.instance: "spine-node"}


def test_two_running_nodes_both_latch_and_stop():
    lc = lcm.LCM("memq://")
    a, b = _node(lc), _node(lc)
    for n in (a, b):
        n.io.inbox.command = SpineCommand(mode=Mode.DAMPING)
    for k in range(30):
        sa, sb = a.tick(k * 1e-3, None), b.tick(k * 1e-3, None)
    for s, n in ((sa, a), (sb, b)):
        assert s.faults & Fault.NODE_CONFLICT and s.mode == Mode.DISABLED and not np.any(s.tau_cmd)
        assert n.last_command is not None and not n.last_command.enable
    assert a.io.peers == {b.cfg.instance: "spine-node"} and b.io.peers == {a.cfg.instance: "spine-node"}
    lc.publish(channels.SPINE_COMMAND, codec.encode_command(SpineCommand(mode=Mode.DAMPING, reset=True)))
    assert a.tick(0.031, None).faults & Fault.NODE_CONFLICT  # a reset does not clear it: restart one node
