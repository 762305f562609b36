"""The robot side's one loop, without a simulator: schedule and stamps, feedback as frames, the motor
model (law, timeout, latch, limit), the heartbeat latch, and lockstep's resend of a lost tick."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sparc_quad.robot_side import HeartbeatWatchdog, MotorModel, Port, RobotConfig, RobotSide, as_frame
from spine_module import params as P
from spine_module.buses.cybergear.protocol import DEFAULT_RANGES
from spine_module.messages import Heartbeat, SpineCommand, TorsoState
from spine_module.messages.motor import MotorCommand, MotorFeedback


class FakeBody:
    dt_s = P.CONTROL_PERIOD_S
    quantise = True
    motors_on_bus = False

    def __init__(self) -> None:
        self.q, self.dq = np.array([0.1, -0.2, 0.3]), np.zeros(3)
        self.applied: list[np.ndarray] = []

    def torso(self) -> TorsoState:
        return TorsoState(q1=0.01)

    def feedback(self) -> MotorFeedback:
        return MotorFeedback(q=self.q.copy(), dq=self.dq.copy(), tau=np.zeros(3))

    def joint_state(self):
        return self.q, self.dq

    def step(self, tau_nm) -> None:
        self.applied.append(np.array(tau_nm))

    def record(self, log) -> None:
        pass


class FakePort(Port):
    """Answers every feedback with a command, except that the first answer to tick `lose` is lost."""

    def __init__(self, lose: int | None = None) -> None:
        self.torso: list[TorsoState] = []
        self.hb: list[Heartbeat] = []
        self.cmd: list[SpineCommand] = []
        self.fb: list[MotorFeedback] = []
        self.lose = lose

    def publish_torso(self, t):
        self.torso.append(t)

    def publish_heartbeat(self, h):
        self.hb.append(h)

    def publish_command(self, c):
        self.cmd.append((c.stamp_s, c.seq))

    def publish_feedback(self, fb):
        self.fb.append(fb)

    def take_command(self, timeout_s, want_seq):
        seq = self.fb[-1].seq
        if seq == self.lose and sum(f.seq == seq for f in self.fb) == 1:
            return None  # the datagram is lost: only a resend of the tick gets an answer
        return MotorCommand(tau_ff=np.full(3, 0.5))


def test_schedule_stamps_and_frames():
    port = FakePort()
    robot = RobotSide(FakeBody(), port, SpineCommand())
    robot.run_lockstep(25)
    every = round(P.HEARTBEAT_PERIOD_S / P.CONTROL_PERIOD_S)
    assert [h.stamp_s for h in port.hb] == [k * 1e-3 for k in range(0, 25, every)]
    assert [s for _, s in port.cmd] == list(range(len(range(0, 25, every))))
    assert [t.seq for t in port.torso] == list(range(25)) and port.torso[7].stamp_s == 7000 * 1e-6
    lsb = P.SENSORS.position_lsb_rad
    assert np.allclose(port.fb[0].q / lsb, np.round(port.fb[0].q / lsb), atol=1e-9)
    assert robot.unanswered == 0 and len(robot.log.t) == 25


def test_lockstep_resends_a_lost_tick():
    port = FakePort(lose=3)
    robot = RobotSide(FakeBody(), port, config=RobotConfig(retry_s=0.01))
    robot.run_lockstep(6)
    assert robot.retransmits == 1 and robot.unanswered == 0 and all(robot.log.answered)
    resent = [f for f in port.fb if f.seq == 3]
    assert len(resent) == 2 and resent[0] is resent[1]  # the same tick again, not a new one
    assert [t.seq for t in port.torso].count(3) == 2


def test_feedback_frame_clips_to_the_protocol_ranges():
    fb = as_frame(MotorFeedback(q=np.array([20.0, -20.0, 0.0]), dq=np.array([40.0, 0.0, -40.0]),
                                tau=np.array([0.0, 13.0, -13.0])))
    r = DEFAULT_RANGES
    assert fb.q[:2].tolist() == [r.position_max, -r.position_max]
    assert fb.dq[[0, 2]].tolist() == [r.velocity_max, -r.velocity_max]
    assert fb.tau[1:].tolist() == [r.torque_max, -r.torque_max]


def test_motor_model_law_timeout_latch_and_limit():
    m = MotorModel(command_timeout_s=0.020, torque_limit_nm=12.0)
    q, dq = np.array([0.1, 0.0, -0.1]), np.array([0.0, 1.0, 0.0])
    assert not m.torque(q, dq, 0.0, latched=False).any()  # no command yet
    c = MotorCommand(tau_ff=np.array([0.1, 0.0, 0.0]), q_des=np.zeros(3), dq_des=np.zeros(3),
                     kp=np.full(3, 10.0), kd=np.full(3, 2.0))
    m.accept(c, 1.0)
    expect = c.tau_ff + c.kp * (c.q_des - q) + c.kd * (c.dq_des - dq)
    assert m.torque(q, dq, 1.0, latched=False) == pytest.approx(expect)
    assert not m.torque(q, dq, 1.0, latched=True).any()
    assert m.torque(q, dq, 1.0195, latched=False).any() and not m.torque(q, dq, 1.0205, latched=False).any()
    m.accept(MotorCommand(tau_ff=np.full(3, 50.0)), 2.0)
    assert m.torque(q, dq, 2.0, latched=False).tolist() == [12.0] * 3
    m.accept(MotorCommand(tau_ff=np.full(3, 1.0), enable=False), 3.0)
    assert not m.torque(q, dq, 3.0, latched=False).any()


def test_heartbeat_watchdog_latches_until_a_higher_reset_count():
    w = HeartbeatWatchdog(deadline_s=0.1)
    assert not w.update([], 0.0)  # not armed before the first heartbeat
    assert not w.update([Heartbeat(reset_count=2)], 0.0)
    assert w.update([], 0.1 + 1e-6)
    assert w.update([Heartbeat(reset_count=2)], 0.2)  # back, but no reset asked for
    assert not w.update([Heartbeat(reset_count=3)], 0.21)
    assert math.isclose(w.last_s, 0.21)
