"""A publisher flooding one input channel with random bytes (75 per 1 ms tick, i.e. 75 000 msg/s) cannot
turn into a safety latch: the node's inputs over memq:// (motors on their own bus, as with CAN), the robot
side sending torso state every tick and heartbeats and commands every 10 ticks: no HEARTBEAT_LOST, no
TORSO_STALE, and the garbage counted per channel. The poll's time budget is lifted here so that the test
counts messages, not microseconds on a shared machine; bench/lcm_flood.py measures the tick rate under a
real 75 000 msg/s flood."""

from __future__ import annotations

import random

import lcm
import numpy as np
import pytest

from spine_module import params
from spine_module.buses.base import MotorBus
from spine_module.messages import (
    Fault,
    Heartbeat,
    Mode,
    MotorFeedback,
    SpineCommand,
    TorsoState,
    channels,
    codec,
)
from spine_module.node import Controllers, LcmNodeIO, NodeConfig, SpineNode
from spine_module.node import io as node_io

GARBAGE_PER_TICK = 75
TICKS = 400


class _Motors(MotorBus):
    """Motors on their own bus: the node's LCM handle carries only its inputs and outputs."""

    def send(self, command) -> None:
        pass

    def receive(self, timeout_s: float | None = 0.0):
        return None


@pytest.mark.parametrize("flooded", [channels.HEARTBEAT_ROBOT, channels.TORSO_STATE, channels.SPINE_COMMAND])
def test_garbage_flood_on_one_channel_latches_nothing(flooded, monkeypatch):
    monkeypatch.setattr(node_io, "POLL_BUDGET_S", 1.0)
    rng = random.Random(3)
    lc = lcm.LCM("memq://")
    io = LcmNodeIO(lc)
    node = SpineNode(Controllers.default(), _Motors(), io, NodeConfig())
    q0 = params.Q_EQUILIBRIUM[1:]
    faults = 0
    modes = []
    for k in range(1, TICKS + 1):
        t = k * 1e-3
        for _ in range(GARBAGE_PER_TICK // 2):
            lc.publish(flooded, rng.randbytes(rng.choice((0, 7, 8, 41, 120))))
        lc.publish(channels.TORSO_STATE, codec.encode_torso(TorsoState(q1=0.0, stamp_s=t, seq=k)))
        if k % 10 == 1:
            lc.publish(channels.HEARTBEAT_ROBOT, codec.encode_heartbeat(Heartbeat("robot", False, 0, t, k)))
            lc.publish(channels.SPINE_COMMAND, codec.encode_command(SpineCommand(mode=Mode.DAMPING, stamp_s=t,
                                                                                  seq=k)))
        for _ in range(GARBAGE_PER_TICK - GARBAGE_PER_TICK // 2):
            lc.publish(flooded, rng.randbytes(rng.choice((0, 7, 8, 41, 120))))
        fb = MotorFeedback(q=q0, dq=np.zeros(3), tau=np.zeros(3), stamp_s=t, seq=k)
        s = node.tick(t, fb)
        assert io.handled_last_poll <= node_io.MAX_MESSAGES_PER_POLL
        if k > 20:  # after the first heartbeat and torso state
            faults |= int(s.faults) & int(Fault.HEARTBEAT_LOST | Fault.TORSO_STALE | Fault.COMMAND_STALE)
            modes.append(s.mode)
    assert faults == 0, Fault(faults)
    assert set(modes) == {Mode.DAMPING}
    assert io.inbox.rejected[flooded] == TICKS * GARBAGE_PER_TICK
    assert all(n == 0 for ch, n in io.inbox.rejected.items() if ch != flooded)
