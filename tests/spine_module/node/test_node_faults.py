"""Fault injection, one test per safety behaviour; each asserts that the safe state is reached within its
deadline, read off the node's own timestamps (the stamps of its spine states)."""

from __future__ import annotations

import logging

import numpy as np
import pytest

from spine_module import params as P
from spine_module.messages import Fault, Mode, SpineCommand, channels, codec
from spine_module.safety import SafetyConfig
from tests.node_harness import DT, FakeController, Harness

SAFETY = P.SAFETY


def _within_deadline(t_last_input: float, t_safe: float, deadline: float) -> None:
    """Reached no earlier than the deadline and at most one tick after it."""
    assert deadline - 1e-9 <= t_safe - t_last_input <= deadline + DT + 1e-9, (t_last_input, t_safe, deadline)


def _running(h: Harness) -> None:
    h.step(600)  # past the 0.5 s soft start
    s = h.states[-1]
    assert s.mode == Mode.IMPEDANCE and s.faults == Fault.NONE and s.gain_scale == 1.0
    np.testing.assert_allclose(s.tau_cmd, h.ctrl.tau)


def test_starts_waiting_with_motors_stopped():
    h = Harness()
    h.send_heartbeat = False
    s = h.step(5)
    assert s.faults & Fault.WAITING and s.mode == Mode.DISABLED
    assert all(c is not None and not c.enable and not c.tau_ff.any() for c in h.commands)


def test_torso_stale_falls_back_to_damping_and_recovers():
    h = Harness()
    _running(h)
    h.dq = np.array([1.0, -1.0, 0.5])
    t_last = h.t - DT
    h.send_torso = False
    h.step(40)
    safe = h.first(lambda s: s.mode == Mode.DAMPING and s.faults & Fault.TORSO_STALE, after=t_last)
    assert safe is not None
    _within_deadline(t_last, safe.stamp_s, SAFETY.torso_deadline_s)
    np.testing.assert_allclose(safe.tau_cmd, -SAFETY.damping_mode_nm_s_rad * h.dq)
    assert all(s.mode == Mode.IMPEDANCE for s in h.states if t_last <= s.stamp_s < safe.stamp_s)
    h.send_torso = True
    t_back = h.t
    s = h.step()
    assert s.mode == Mode.IMPEDANCE and not s.faults & Fault.TORSO_STALE and s.stamp_s == t_back
    assert s.gain_scale == 0.0  # recovery soft-starts again
    h.step(600)
    assert h.states[-1].gain_scale == 1.0


def test_feedback_stale_commands_zero_torque():
    h = Harness()
    _running(h)
    t_last = h.t - DT
    h.send_feedback = False
    h.step(20)
    safe = h.first(lambda s: s.faults & Fault.FEEDBACK_STALE, after=t_last)
    _within_deadline(t_last, safe.stamp_s, SAFETY.feedback_deadline_s)
    i = h.states.index(safe)
    assert all(not c.tau_ff.any() for c in h.commands[i:])
    h.send_feedback = True
    s = h.step()
    assert s.mode == Mode.IMPEDANCE and not s.faults & Fault.FEEDBACK_STALE


def test_command_stale_holds_last_target_with_default_gains():
    cmd = SpineCommand(mode=Mode.PD, x_d=np.array([0.26, 0.01, 0.05]), k=np.array([300.0, 800.0, 10.0]),
                       d=np.array([2.0, 5.0, 0.1]), tau_ff=np.array([0.1, 0.1, 0.1]))
    h = Harness(command=cmd)
    h.step(600)
    np.testing.assert_allclose(h.ctrl.k, cmd.k)
    t_last = h.t - DT - (h.k - 1) % 10 * DT  # last command went out on a multiple of 10 ticks
    h.send_command = False
    h.step(250)
    safe = h.first(lambda s: s.faults & Fault.COMMAND_STALE, after=t_last)
    _within_deadline(t_last, safe.stamp_s, SAFETY.command_deadline_s)
    assert safe.mode == Mode.IMPEDANCE and safe.requested_mode == Mode.PD
    np.testing.assert_allclose(h.ctrl.k, P.K_DEFAULT)
    np.testing.assert_allclose(h.ctrl.d, P.D_DEFAULT)
    np.testing.assert_allclose(h.ctrl.x_d, cmd.x_d)
    np.testing.assert_allclose(h.states[-1].tau_cmd, h.ctrl.tau)  # no feed-forward while holding


def test_heartbeat_loss_latches_until_reset(caplog):
    h = Harness()
    _running(h)
    t_last = h.t - DT - (h.k - 1) % 10 * DT
    h.send_heartbeat = False
    with caplog.at_level(logging.WARNING, logger="spine_module.node"):
        h.step(150)
    safe = h.first(lambda s: s.faults & Fault.HEARTBEAT_LOST, after=t_last)
    _within_deadline(t_last, safe.stamp_s, SAFETY.heartbeat_deadline_s)
    i = h.states.index(safe)
    assert all(not c.enable and not c.tau_ff.any() for c in h.commands[i:])
    assert "HEARTBEAT_LOST" in caplog.text
    h.send_heartbeat = True
    h.step(50)
    assert h.states[-1].faults & Fault.HEARTBEAT_LOST and h.states[-1].mode == Mode.DISABLED  # still latched
    assert h.io.heartbeats[-1].fault  # and says so to the robot side
    h.command.reset = True
    h.step(1)
    h.command.reset = False
    h.step(10)
    s = h.states[-1]
    assert not s.faults & Fault.HEARTBEAT_LOST and s.mode == Mode.IMPEDANCE
    assert h.io.heartbeats[-1].reset_count == 1 and not h.io.heartbeats[-1].fault


def test_estop_latches_until_reset():
    h = Harness()
    _running(h)
    h.command = SpineCommand(mode=Mode.ESTOP)
    t_sent = h.t + (10 - h.k % 10) % 10 * DT
    h.step(20)
    safe = h.first(lambda s: s.mode == Mode.ESTOP, after=t_sent - DT)
    assert safe.stamp_s == pytest.approx(t_sent) and safe.faults & Fault.ESTOP  # the same tick
    i = h.states.index(safe)
    assert all(not c.enable and not c.tau_ff.any() for c in h.commands[i:])
    h.command = SpineCommand(mode=Mode.IMPEDANCE)
    h.step(30)
    assert h.states[-1].mode == Mode.ESTOP  # a new mode alone does not clear it
    h.command = SpineCommand(mode=Mode.IMPEDANCE, reset=True)
    h.step(30)
    s = h.states[-1]
    assert s.mode == Mode.IMPEDANCE and not s.faults & Fault.ESTOP and 0 < s.gain_scale < 1  # soft start


@pytest.mark.parametrize(("channel", "field", "value", "bit"), [
    (channels.SPINE_COMMAND, "k", [float("nan"), 1000.0, 15.0], Fault.BAD_COMMAND),
    (channels.SPINE_COMMAND, "tau_ff", [0.0, float("inf"), 0.0], Fault.BAD_COMMAND),
    (channels.SPINE_COMMAND, "x_d", [5.0, 0.0, 0.0], Fault.BAD_COMMAND),
    (channels.TORSO_STATE, "q1", float("nan"), Fault.BAD_TORSO),
])
def test_bad_fields_rejected_and_named(caplog, channel, field, value, bit):
    h = Harness()
    _running(h)
    good = codec.encode_command(SpineCommand()) if channel == channels.SPINE_COMMAND else \
        codec.encode_torso(h.node.torso)
    raw = codec.decode_raw(channel, good)
    setattr(raw, field, value)

    def inject(hh):
        hh.io.deliver(channel, raw.encode())

    with caplog.at_level(logging.WARNING, logger="spine_module.node"):
        s = h.step(1, extra=inject)
    label = f"{field}[0]" if field in ("k", "x_d") else (f"{field}[1]" if field == "tau_ff" else field)
    assert s.faults & bit and s.rejected.startswith(f"{channel}.{label}:")
    assert f"{channel}.{label}" in caplog.text
    assert s.mode == Mode.IMPEDANCE and h.node.command.k[0] == P.K_DEFAULT[0]  # last good command in force
    h.step(99)
    assert h.states[-1].faults & bit  # shown for bad_hold_s after the rejection
    h.step(2)
    assert not h.states[-1].faults & bit  # then clears; `rejected` keeps the story
    assert h.states[-1].rejected.startswith(f"{channel}.{label}:")


def test_wrong_fingerprint_and_garbage_are_rejected_loop_survives():
    h = Harness()
    _running(h)

    def inject(hh):
        hh.io.deliver(channels.SPINE_COMMAND, codec.encode_torso(hh.node.torso))
        hh.io.deliver(channels.TORSO_STATE, b"\x00\x01garbage")

    s = h.step(1, extra=inject)
    assert s.faults & Fault.BAD_COMMAND and s.faults & Fault.BAD_TORSO
    assert "fingerprint" in s.rejected or "malformed" in s.rejected
    assert s.mode == Mode.IMPEDANCE


def test_non_finite_motor_feedback_rejected():
    h = Harness()
    _running(h)
    h.q = np.array([np.nan, 1.8, -0.9])
    s = h.step(1)
    assert s.faults & Fault.BAD_FEEDBACK
    h.step(10)
    assert h.states[-1].faults & Fault.BAD_FEEDBACK
    assert h.states[-1].faults & Fault.FEEDBACK_STALE and not h.commands[-1].tau_ff.any()


def test_torque_clamps_at_limit():
    h = Harness(ctrl=FakeController(tau=(30.0, -12.5, 3.0)))
    h.step(600)
    s = h.states[-1]
    np.testing.assert_array_equal(s.tau_cmd, [12.0, -12.0, 3.0])
    np.testing.assert_array_equal(h.commands[-1].tau_ff, [12.0, -12.0, 3.0])
    assert s.faults & Fault.TORQUE_CLAMPED


def test_joint_limit_adds_damping_and_reports_it():
    h = Harness()
    _running(h)
    upper = P.JOINT_UPPER_RAD["q2"]
    h.q = np.array([upper - 0.02, 1.8, -0.9])
    h.dq = np.array([1.0, 0.0, 0.0])
    s = h.step()
    assert s.faults & Fault.JOINT_LIMIT
    depth = 1 - 0.02 / P.JOINT_LIMIT_MARGIN_RAD
    expected = h.ctrl.tau[0] - SAFETY.joint_limit_damping_nm_s_rad * depth * 1.0
    assert s.tau_cmd[0] == pytest.approx(expected)


def test_soft_start_ramps_gains():
    h = Harness(command=SpineCommand(mode=Mode.IMPEDANCE, k=np.array([400.0, 1000.0, 15.0])))
    h.step(1)
    t0 = h.states[0].stamp_s
    ks = []
    for _ in range(600):
        s = h.step()
        ks.append((s.stamp_s, s.gain_scale, h.ctrl.k[0]))
    for t, scale, k in ks:
        expect = min(1.0, (t - t0) / SAFETY.soft_start_s)
        assert scale == pytest.approx(expect) and k == pytest.approx(400.0 * expect)
    assert ks[-1][1] == 1.0


def test_soft_start_configurable():
    h = Harness(safety=SafetyConfig(soft_start_s=0.1))
    h.step(101)
    assert h.states[-1].gain_scale == 1.0 and h.states[50].gain_scale == pytest.approx(0.5)


def test_controller_failure_gives_zero_torque_and_loop_survives():
    h = Harness()
    _running(h)
    h.ctrl.ok = False
    s = h.step()
    assert s.faults & Fault.CONTROLLER and not s.tau_cmd.any()
    h.ctrl.ok, h.ctrl.raises = True, True
    s = h.step()
    assert s.faults & Fault.CONTROLLER and not s.tau_cmd.any()
    h.ctrl.raises = False
    s = h.step()
    assert not s.faults & Fault.CONTROLLER and s.tau_cmd.any()


def test_loop_timing_is_reported():
    h = Harness()
    s = h.step(5)
    assert s.compute > 0 and s.period > 0 and s.jitter_max >= 0


def test_lockstep_repeated_tick_is_answered_again_without_stepping():
    """UDP may drop an answer: the robot repeats the tick and the node re-sends its command."""
    import threading

    from spine_module.buses.base import MotorFeedback
    from spine_module.messages import Heartbeat, TorsoState
    from spine_module.node import run_lockstep

    h = Harness()
    answers = []

    def robot():
        for k in range(20):
            t = k * DT
            if k % 10 == 0:
                h.io.send_heartbeat(Heartbeat("r", stamp_s=t, seq=k))
                h.io.send_command(SpineCommand(stamp_s=t, seq=k))
            h.io.send_torso(TorsoState(stamp_s=t, seq=k))
            fb = MotorFeedback(q=h.q.copy(), dq=np.zeros(3), tau=np.zeros(3), stamp_s=t, seq=k)
            for _ in range(2 if k == 5 else 1):
                h.link.robot.publish_feedback(fb)
                answers.append(h.link.robot.take_command(2.0))

    th = threading.Thread(target=robot)
    th.start()
    run_lockstep(h.node, max_ticks=20, idle_timeout_s=1.0)
    th.join()
    assert h.node.seq == 20 and h.node.repeated_ticks == 1
    assert all(a is not None for a in answers) and len(answers) == 21
    assert answers[5][1] == answers[6][1] == 5 and answers[5][0].seq == answers[6][0].seq


def test_unexpected_exception_in_a_tick_stops_motors_and_the_loop_goes_on(caplog):
    h = Harness()
    _running(h)
    calls = {"n": 0}
    original = h.io.publish_state

    def flaky(state):
        calls["n"] += 1
        if calls["n"] == 1:
            raise OSError("disk full")
        original(state)

    h.io.publish_state = flaky
    h.link.robot.publish_feedback(h.node.fb)
    with caplog.at_level(logging.ERROR, logger="spine_module.node"):
        h.node.safe_tick(h.t, h.node.receive(0.0))
    cmd, _ = h.link.robot.take_command(0.0)
    assert not cmd.enable and not cmd.tau_ff.any() and h.node.tick_errors == 1
    assert "control tick failed" in caplog.text
    h.k += 1
    s = h.step(1)
    assert s.mode == Mode.IMPEDANCE and h.commands[-1].tau_ff.any()


def test_soft_start_moves_the_target_in_from_the_current_pose():
    x_cmd = np.array([0.27, 0.0, 0.0])
    h = Harness(command=SpineCommand(mode=Mode.IMPEDANCE, x_d=x_cmd.copy()))
    x0 = np.array([0.25, -0.02, 0.1])
    h.node.ctrl.task_state = lambda q, dq: (x0.copy(), np.zeros(3))
    h.step(1)
    for _ in range(600):
        s = h.step()
        expect = x0 + min(1.0, s.gain_scale) * (x_cmd - x0)
        np.testing.assert_allclose(h.ctrl.x_d, expect, atol=1e-12)
    np.testing.assert_allclose(h.ctrl.x_d, x_cmd)


def test_friction_compensation_follows_the_command():
    """The command's friction_compensation flag switches eq. (4) on the node's one impedance controller:
    with the same state, the commanded torques differ by exactly the Stribeck torque of the joint speeds."""
    from spine_module.control import StribeckFriction
    from spine_module.node import Controllers

    tau = {}
    for flag in (True, False):
        h = Harness(command=SpineCommand(mode=Mode.IMPEDANCE, friction_compensation=flag))
        h.node.ctrl = Controllers.default()
        h.dq = np.array([0.5, -0.5, 0.2])
        h.step(600)  # past the soft start
        assert h.node.ctrl.impedance.friction_enabled is flag
        tau[flag] = np.array(h.states[-1].tau_cmd)
    np.testing.assert_allclose(tau[True] - tau[False], StribeckFriction.nominal().torque(h.dq), atol=1e-9)
