"""Issue 31, "fresh inputs only": what waited in a queue while the node was not looking is not fresh.

- a stall (the node does not tick while the robot keeps publishing) ends in the stale faults of every input
  whose deadline is shorter than the gap, on the first tick after it, with zero torque; past
  `stale_resume_s` the gains soft-start again (before: full gain on inputs as old as the stall);
- inputs queued before the real-time loop starts are dropped and counted, never used (LCM memq://);
- the first tick of a soft start (start-up, after a latch, after a stale spell) commands zero torque,
  gravity and feed-forward included (before: the fake law's 0.5 N*m at once).
"""

from __future__ import annotations

import lcm
import numpy as np

from spine_module import params as P
from spine_module.buses.inprocess import InProcessBus, InProcessLink
from spine_module.messages import Fault, Heartbeat, Mode, SpineCommand, TorsoState, channels, codec
from spine_module.node import Controllers, LcmNodeIO, NodeConfig, SpineNode, run_realtime
from spine_module.node.runner import RunResult
from tests.node_harness import DT, FakeController, Harness

SAFETY = P.SAFETY


def _running(h: Harness) -> None:
    h.step(600)
    s = h.states[-1]
    assert s.mode == Mode.IMPEDANCE and s.faults == Fault.NONE and s.gain_scale == 1.0


def _stall(h: Harness, ms: int) -> None:
    """The robot publishes every input each ms for `ms` ms; the node does not tick (it is stalled)."""
    from spine_module.buses.base import MotorFeedback

    for _ in range(ms):
        t = h.t
        h.io.send_heartbeat(Heartbeat("test-robot", stamp_s=t, seq=h.k))
        h.io.send_torso(TorsoState(stamp_s=t, seq=h.k))
        h.command.stamp_s, h.command.seq = t, h.k
        h.io.send_command(h.command)
        h.link.robot.publish_feedback(MotorFeedback(q=h.q.copy(), dq=h.dq.copy(), tau=np.zeros(3), stamp_s=t,
                                                    seq=h.k))
        h.k += 1


def test_a_stall_raises_the_stale_faults_and_soft_starts_again():
    h = Harness()
    _running(h)
    _stall(h, 226)
    s = h.step()
    # every input counts as arrived when the stall began: older than its deadline (5, 20, 100, 200 ms)
    stale = Fault.FEEDBACK_STALE | Fault.TORSO_STALE | Fault.HEARTBEAT_LOST | Fault.COMMAND_STALE
    assert s.faults & stale == stale, s.faults
    assert not np.any(s.tau_cmd) and h.node.stalls == 1


def test_after_a_stall_the_gains_soft_start_again():
    for stall_ms in (30, 226):  # torso stale in both (20 ms): its recovery soft-starts, as documented
        h = Harness()
        h.node.cfg.safety = type(h.node.cfg.safety)(heartbeat_required=False)
        _running(h)
        _stall(h, stall_ms)
        s = h.step()
        assert s.faults & Fault.FEEDBACK_STALE and s.faults & Fault.TORSO_STALE and not np.any(s.tau_cmd)
        s = h.step()
        assert s.mode == Mode.IMPEDANCE and not s.faults & (Fault.FEEDBACK_STALE | Fault.TORSO_STALE)
        assert s.gain_scale == 0.0 and not np.any(s.tau_cmd), (stall_ms, s.gain_scale)
        h.step(10)
        assert 0.0 < h.states[-1].gain_scale < 0.05


def test_a_short_tick_gap_is_no_stall():
    """A late tick within the feedback deadline (5 ms) changes nothing: inputs are fresh."""
    h = Harness()
    _running(h)
    _stall(h, 4)
    s = h.step()
    assert s.faults == Fault.NONE and s.gain_scale == 1.0 and h.node.stalls == 0


def test_first_tick_of_every_soft_start_commands_zero_torque():
    h = Harness()
    h.step(1)
    first = h.first(lambda s: s.mode == Mode.IMPEDANCE)
    assert first is None or not np.any(first.tau_cmd)
    h.step(20)
    first = h.first(lambda s: s.mode == Mode.IMPEDANCE)
    assert first is not None and first.gain_scale == 0.0 and not np.any(first.tau_cmd)
    nxt = h.states[h.states.index(first) + 1]
    assert 0.0 < nxt.gain_scale < 0.01 and h.ctrl.k is not None  # then K and D ramp from 0
    # after an E-stop latch and its reset
    h.command = SpineCommand(mode=Mode.ESTOP)
    h.step(20)
    h.command = SpineCommand(mode=Mode.IMPEDANCE, reset=True)
    t_reset = h.t
    h.step(30)
    back = h.first(lambda s: s.mode == Mode.IMPEDANCE, after=t_reset - DT / 2)
    assert back is not None and back.gain_scale == 0.0 and not np.any(back.tau_cmd)


def test_inputs_queued_before_the_loop_are_dropped_not_used():
    """memq://: 100 torso states, a command and a heartbeat wait in LCM's queue when the loop starts (the
    node took 0.5-1 s to start, issue 31); none is used, all are counted."""
    lc = lcm.LCM("memq://")
    io = LcmNodeIO(lc)
    states = []
    lc.subscribe(channels.SPINE_STATE, lambda ch, data: states.append(codec.decode_state(data)))
    for k in range(100):
        lc.publish(channels.TORSO_STATE, codec.encode_torso(TorsoState(stamp_s=k * 1e-3, seq=k)))
    lc.publish(channels.SPINE_COMMAND, codec.encode_command(SpineCommand(mode=Mode.IMPEDANCE, seq=1)))
    lc.publish(channels.HEARTBEAT_ROBOT, codec.encode_heartbeat(Heartbeat("robot", stamp_s=0.0, seq=1)))
    ctrl = Controllers(impedance=FakeController(), pd=FakeController())
    node = SpineNode(ctrl, InProcessBus(InProcessLink()), io, NodeConfig())
    res = run_realtime(node, max_ticks_stop(node, 20))
    assert isinstance(res, RunResult) and res.ticks >= 1
    assert node.drained_at_start >= 100
    assert states and all(s.torso_seq == -1 and s.command_seq == -1 for s in states), \
        [(s.torso_seq, s.command_seq) for s in states[:3]]
    assert all(s.faults & Fault.TORSO_STALE and not np.any(s.tau_cmd) for s in states)


def max_ticks_stop(node: SpineNode, n: int) -> float:
    """A duration of n ticks of node time at the node's rate (run_realtime's stop condition)."""
    return n / node.cfg.rate_hz
