"""The lockstep wait over LCM: poll for `spin_s`, then block for the rest of the timeout."""

from __future__ import annotations

import math

import lcm
import numpy as np
import pytest

from sparc_quad.robot_side.ports import LcmPort
from spine_module.buses import lcm as lcm_bus
from spine_module.buses.base import MotorFeedback
from spine_module.buses.lcm import LcmMotorBus, handle
from spine_module.messages import channels, codec


class FakeLcm:
    """`handle_timeout` answers from a script; every call advances a fake clock by `step_s`."""

    def __init__(self, answers: list[int], clock: list[float], step_s: float) -> None:
        self.answers, self.clock, self.step_s = answers, clock, step_s
        self.calls: list[int] = []

    def handle_timeout(self, ms: int) -> int:
        self.calls.append(ms)
        self.clock[0] += self.step_s
        return self.answers.pop(0) if self.answers else 0


@pytest.fixture
def fake_clock(monkeypatch):
    now = [0.0]
    monkeypatch.setattr(lcm_bus, "_clock", lambda: now[0])
    monkeypatch.setattr(lcm_bus, "_yield_cpu", lambda: None)
    return now


def test_a_message_during_the_spin_is_taken_without_blocking(fake_clock):
    lc = FakeLcm([0, 0, 1], fake_clock, step_s=1e-5)
    assert handle(lc, timeout_s=0.05, spin_s=0.001) == 1
    assert lc.calls == [0, 0, 0]  # polls only


def test_after_the_spin_the_wait_blocks_for_the_rest_of_the_timeout(fake_clock):
    lc = FakeLcm([], fake_clock, step_s=2**-14)  # binary fractions: the fake clock adds up exactly
    assert handle(lc, timeout_s=0.05, spin_s=2**-10) == 0
    polls, block = lc.calls[:-1], lc.calls[-1]
    assert polls and set(polls) == {0} and len(polls) == 16  # ~1 ms of polls, ~61 us each
    assert block == 49  # the 49 ms left of the 50 ms timeout, blocking


def test_no_spin_blocks_at_once(fake_clock):
    lc = FakeLcm([1], fake_clock, step_s=1e-5)
    assert handle(lc, timeout_s=0.02, spin_s=0.0) == 1
    assert lc.calls == [20]


def test_a_timeout_shorter_than_the_spin_only_polls(fake_clock):
    lc = FakeLcm([], fake_clock, step_s=1e-4)
    assert handle(lc, timeout_s=0.0005, spin_s=0.001) == 0
    assert set(lc.calls) == {0}


def test_spinning_bus_receives_feedback_over_memq():
    lc = lcm.LCM("memq://")
    bus = LcmMotorBus(lc=lc, spin_s=0.001)
    fb = MotorFeedback(q=np.array([0.1, -0.2, 0.3]), dq=np.zeros(3), tau=np.zeros(3), seq=7)
    lc.publish(channels.MOTOR_FEEDBACK, codec.encode_motor_feedback(fb))
    got = bus.receive(0.05)
    assert got is not None and got.seq == 7 and got.q.tolist() == pytest.approx([0.1, -0.2, 0.3])
    assert bus.receive(0.002) is None  # nothing more: polls, blocks the rest, returns None


@pytest.mark.parametrize("bad", [-1e-6, math.nan])
def test_a_negative_or_nan_spin_is_refused(bad):
    lc = lcm.LCM("memq://")
    with pytest.raises(ValueError, match="spin_s"):
        LcmMotorBus(lc=lc, spin_s=bad)
    with pytest.raises(ValueError, match="spin_s"):
        LcmPort(lc=lc, spin_s=bad)


class InterruptedLcm:
    """A real in-process LCM whose every dispatch is cut by a signal (LCM returns -1: OSError)."""

    def __init__(self) -> None:
        self.real = lcm.LCM("memq://")
        self.cuts = 0

    def __getattr__(self, name):
        return getattr(self.real, name)

    def handle_timeout(self, ms: int) -> int:
        self.cuts += 1
        raise OSError("lcm_handle_timeout() returned -1")


def test_a_signal_during_any_dispatch_is_nothing_dispatched():
    """SIGTERM during a zero-timeout poll in a receive ended a node as "internal error" (exit 1, seen in
    tests/integration/test_node_signals.py); every dispatch now reads it as nothing dispatched."""
    from spine_module.node.io import LcmNodeIO

    lc = InterruptedLcm()
    assert handle(lc, 0.005) == 0 and handle(lc, 0.005, spin_s=0.001) == 0
    bus = LcmMotorBus(lc=lc)
    assert bus.receive(0.0) is None and bus.receive(0.002) is None
    io = LcmNodeIO(lc)
    io.poll()
    assert io.drain() == 0 and io.await_torso(10**6, 0.003) is False
    assert lc.cuts >= 6
