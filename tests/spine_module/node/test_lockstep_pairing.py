"""Lockstep gives each tick the torso state of that tick, whatever order the transport delivers a tick's
torso state and motor feedback in (LCM's mpudpm, a socket per channel, does not keep it)."""

from __future__ import annotations

import threading

import numpy as np

from spine_module.buses.base import MotorFeedback
from spine_module.messages import Fault, Heartbeat, SpineCommand, TorsoState, channels
from spine_module.node import InProcessNodeIO, run_lockstep
from tests.node_harness import DT, Harness

TICKS = 30


class LateIO(InProcessNodeIO):
    """A transport on which a tick's messages on `late` channels arrive after its motor feedback, before
    the next tick's: they are held until the robot sends the next one on that channel, or until the node
    waits for them (`await_torso`, `await_inbox`)."""

    def __init__(self, late=(channels.TORSO_STATE,)) -> None:
        super().__init__()
        self._lock = threading.Lock()
        self._late = frozenset(late)
        self._in_flight: dict[str, bytes] = {}
        self.inbox_waits = 0  # opening waits that found something still in flight

    def deliver(self, channel: str, data: bytes) -> None:
        if channel not in self._late:
            super().deliver(channel, data)
            return
        with self._lock:
            arrived = self._in_flight.pop(channel, None)
            self._in_flight[channel] = data
        if arrived is not None:
            super().deliver(channel, arrived)

    def _release(self) -> None:
        with self._lock:
            arrived, self._in_flight = self._in_flight, {}
        for channel, d in arrived.items():
            super().deliver(channel, d)

    def await_torso(self, seq: int, timeout_s: float) -> bool:
        if not super().await_torso(seq, timeout_s):
            self.torso_waits += 1
            self._release()
        return super().await_torso(seq, timeout_s)

    def await_inbox(self, ready, timeout_s: float) -> bool:
        if not ready(self.inbox):
            self.inbox_waits += 1
            self._release()
        return ready(self.inbox)


def _q1(k: int) -> float:
    return 0.001 * (k + 1)


def _run(torso_seq=lambda k: k, torso_until: int = TICKS, late=(channels.TORSO_STATE,)) -> Harness:
    """Lockstep with a robot thread; torso state k carries q1 = _q1(k) and seq torso_seq(k)."""
    h = Harness()
    h.io = LateIO(late)
    h.node.io = h.io
    answers = []

    def robot():
        for k in range(TICKS):
            t = k * DT
            if k % 10 == 0:
                h.io.send_heartbeat(Heartbeat("r", stamp_s=t, seq=k))
                h.io.send_command(SpineCommand(stamp_s=t, seq=k))
            if k < torso_until:
                h.io.send_torso(TorsoState(q1=_q1(k), stamp_s=t, seq=torso_seq(k)))
            h.link.robot.publish_feedback(MotorFeedback(q=h.q.copy(), dq=np.zeros(3), tau=np.zeros(3),
                                                        stamp_s=t, seq=k))
            answers.append(h.link.robot.take_command(5.0))

    th = threading.Thread(target=robot)
    th.start()
    run_lockstep(h.node, max_ticks=TICKS, idle_timeout_s=5.0)
    th.join()
    assert all(a is not None for a in answers) and h.node.seq == TICKS
    return h


def _q1_per_tick(h: Harness) -> np.ndarray:
    return np.array([s.q[0] for s in h.io.states])


def test_each_tick_runs_on_its_own_torso_state_when_it_arrives_after_the_feedback():
    h = _run()
    q1 = _q1_per_tick(h)
    # the first tick waits for the robot's opening messages, the others for their own torso state
    np.testing.assert_array_equal(q1, [_q1(k) for k in range(TICKS)])
    assert h.io.inbox_waits == 1 and h.io.torso_waits == TICKS - 1 and h.node.lockstep_torso_missing == 0
    assert not h.node.lockstep_opening_incomplete


def test_the_first_tick_runs_the_commanded_mode_when_heartbeat_and_command_come_after_the_feedback():
    late = _run(late=(channels.HEARTBEAT_ROBOT, channels.SPINE_COMMAND))
    on_time = _run(late=())
    assert late.io.inbox_waits == 1 and on_time.io.inbox_waits == 0
    assert not late.node.lockstep_opening_incomplete
    assert [s.mode for s in late.io.states] == [s.mode for s in on_time.io.states]
    assert not late.io.states[0].faults & Fault.WAITING


def test_a_robot_that_sends_no_command_costs_the_first_tick_one_wait():
    h = Harness()
    h.io = LateIO(())
    h.node.io = h.io

    def robot():
        h.io.send_torso(TorsoState(q1=0.1, stamp_s=0.0, seq=0))
        h.link.robot.publish_feedback(MotorFeedback(q=h.q.copy(), dq=np.zeros(3), tau=np.zeros(3),
                                                    stamp_s=0.0, seq=0))
        h.link.robot.take_command(5.0)

    th = threading.Thread(target=robot)
    th.start()
    run_lockstep(h.node, max_ticks=1, idle_timeout_s=5.0)
    th.join()
    assert h.node.lockstep_opening_incomplete and h.io.states[0].faults & Fault.WAITING


def test_a_robot_that_stops_sending_torso_states_costs_one_wait():
    h = _run(torso_until=10)
    assert h.node.lockstep_torso_missing == 1 and h.io.torso_waits == 9 + 1
    assert _q1_per_tick(h)[-1] == _q1(9)  # the last torso state it sent, judged by the stale watchdog


def test_torso_states_numbered_otherwise_are_not_waited_for():
    h = _run(torso_seq=lambda k: 1000 + 3 * k)
    assert h.io.torso_waits == 0 and h.node.lockstep_torso_missing == 0
    np.testing.assert_array_equal(_q1_per_tick(h)[1:], [_q1(k - 1) for k in range(1, TICKS)])


def test_lcm_io_dispatches_until_the_torso_state_of_the_tick_is_in():
    import lcm

    from spine_module.messages import codec
    from spine_module.node.io import LcmNodeIO

    lc = lcm.LCM("memq://")
    io = LcmNodeIO(lc)
    lc.publish(channels.HEARTBEAT_ROBOT, codec.encode_heartbeat(Heartbeat("r", seq=1)))
    lc.publish(channels.TORSO_STATE, codec.encode_torso(TorsoState(q1=0.2, seq=7)))
    assert io.await_torso(7, 5.0) and io.inbox.torso.q1 == 0.2 and io.torso_waits == 1
    assert io.inbox.heartbeat is not None  # what came before it is dispatched too, not dropped
    assert io.await_torso(7, 5.0) and io.torso_waits == 1  # already in: no wait
    assert not io.await_torso(8, 0.01) and io.torso_waits == 2  # never sent: gives up
    io.close()
