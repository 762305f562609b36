"""The robot side's one loop: per tick, publish torso state, heartbeat and spine command on schedule and
the motor feedback last; then take the node's motor command, let the motors apply it, step the body.

- lockstep: wait for the command answering this tick's feedback, so a co-simulation is deterministic
  whatever the machine's speed (time = ticks x dt); every `retry_s` without an answer the tick's torso
  state and feedback are sent again (UDP may drop a datagram; the node answers a repeated tick with its
  previous command, without stepping again);
- real time: step on a wall clock and apply whatever command is newest;
- `cosim(k, t)`: a node in this thread, ticked between publishing and taking its answer.

Robot time is exact in microseconds, as on the wire. Like SPARC's PMU the robot watches the node's
heartbeat (`HeartbeatWatchdog`); the motors (`MotorModel`) hold the newest command with a timeout.
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from sparc_quad.robot_side.bodies import Body
from sparc_quad.robot_side.motors import MotorModel, as_frame
from sparc_quad.robot_side.ports import Port
from sparc_quad.robot_side.watchdog import HeartbeatWatchdog
from spine_module import params as P
from spine_module.messages import Heartbeat, SpineCommand, TorsoState
from spine_module.messages.motor import MotorCommand, MotorFeedback
from spine_module.node.clocks import RealTimeClock

log = logging.getLogger("sparc_quad.robot_side")


@dataclass
class RobotConfig:
    heartbeat_period_s: float = P.HEARTBEAT_PERIOD_S
    heartbeat_deadline_s: float = P.SAFETY.heartbeat_deadline_s
    command_period_s: float = P.SPINE_COMMAND_PERIOD_S  # spine command from the script, robot time
    lockstep_timeout_s: float = 2.0  # wall time to wait for the node's answer before giving up on a tick
    command_timeout_s: float = P.MOTOR_COMMAND_TIMEOUT_S  # robot clock
    retry_s: float = 0.2  # lockstep: resend the tick when its answer has not come within this (wall s)
    name: str = "bench-robot"


class RobotLog:
    """Per tick: robot time `t` s, whether a command answered the tick, the robot's latched fault, the
    lockstep round trip (feedback out -> answer in, wall s; NaN otherwise), and the body's columns (bench:
    true q rad, true task pose x, applied F_x and load-cell reading N, applied torque N*m)."""

    def __init__(self) -> None:
        self.columns: dict[str, list] = {}

    def add(self, **values) -> None:
        for k, v in values.items():
            self.columns.setdefault(k, []).append(v)

    def __getattr__(self, name: str) -> list:
        try:
            return self.__dict__["columns"][name]
        except KeyError:
            raise AttributeError(name) from None

    def arrays(self) -> dict[str, np.ndarray]:
        return {k: np.array(v) for k, v in self.columns.items()}


class RobotSide:
    def __init__(self, body: Body, port: Port,
                 command: SpineCommand | Callable[[float], SpineCommand] | None = None,
                 config: RobotConfig | None = None,
                 cosim: Callable[[int, float], None] | None = None) -> None:
        self.body, self.port, self.command = body, port, command
        self.cfg = config if config is not None else RobotConfig()
        self.cosim = cosim
        self.dt = body.dt_s
        self._dt_us = round(self.dt * 1e6)
        self._hb_every = max(1, round(self.cfg.heartbeat_period_s / self.dt))
        self._cmd_every = max(1, round(self.cfg.command_period_s / self.dt))
        self.motors = MotorModel(command_timeout_s=self.cfg.command_timeout_s)
        self.watchdog = HeartbeatWatchdog(self.cfg.heartbeat_deadline_s)
        self.log = RobotLog()
        self.k = 0  # tick
        self._hb_seq = 0
        self._cmd_seq = 0
        self.unanswered = 0
        self.retransmits = 0
        self._sent: tuple[TorsoState, MotorFeedback | None] | None = None
        self._clock = 0.0
        self.t_feedback_wall = 0.0

    @property
    def latched(self) -> bool:
        return self.watchdog.latched

    @property
    def last_cmd(self) -> MotorCommand | None:
        return self.motors.command

    def now(self) -> float:
        """Robot time of the current tick, s (exact in microseconds, as on the wire)."""
        return self.k * self._dt_us * 1e-6

    # -- one tick, in two halves ---------------------------------------------------------------------
    def publish_tick(self, wall_now: float | None = None) -> float:
        """Publish torso state, heartbeat and command (when due), then the motor feedback of this tick."""
        k, t = self.k, self.now()
        torso = self.body.torso()
        torso.stamp_s, torso.seq = t, k
        heartbeat = command = None
        if k % self._hb_every == 0:
            heartbeat = Heartbeat(sender=self.cfg.name, fault=self.latched, stamp_s=t, seq=self._hb_seq)
            self._hb_seq += 1
        if self.command is not None and k % self._cmd_every == 0:
            command = self.command(t) if callable(self.command) else self.command
            command.stamp_s, command.seq = t, self._cmd_seq
            self._cmd_seq += 1
        fb = None
        if not self.body.motors_on_bus:
            fb = as_frame(self.body.feedback(), self.body.quantise)
            fb.stamp_s, fb.seq = t, k
        self.t_feedback_wall = self.port.publish_tick(torso, heartbeat, command, fb)
        self._sent = (torso, fb)
        self._clock = t if wall_now is None else wall_now
        self.watchdog.update(self.port.node_heartbeats(), self._clock)
        return t

    def finish_tick(self, cmd: MotorCommand | None, rtt_s: float = math.nan) -> None:
        """Apply `cmd` (None: the motors keep the last one) and step the body by one tick."""
        if not self.body.motors_on_bus:
            self.motors.accept(cmd, self._clock)
            q, dq = self.body.joint_state()
            self.body.step(self.motors.torque(q, dq, self._clock, self.latched))
        self.log.add(t=self.now(), answered=cmd is not None, latched=self.latched, rtt_s=rtt_s)
        self.body.record(self.log)
        self.k += 1

    # -- running -------------------------------------------------------------------------------------
    def tick(self, lockstep: bool = True) -> None:
        """One whole tick: publish, let an in-thread node answer (`cosim`), take the answer, apply, step."""
        self.publish_tick()
        self.finish_tick(*self.answer(lockstep))

    def answer(self, lockstep: bool = True) -> tuple[MotorCommand | None, float]:
        """The node's command for the tick just published and the lockstep round trip (wall s; NaN when
        not waited for). Work that needs only this tick's state can run between `publish_tick` and this,
        while a node in another process computes."""
        if self.cosim is not None:
            self.cosim(self.k, self.now())
            cmd = self.port.take_command(0.0, want_seq=self.k)
            rtt = math.nan
        elif lockstep:
            cmd = self._await_answer()
            rtt = time.perf_counter() - self.t_feedback_wall
        else:
            cmd, rtt = self.port.take_command(0.0, want_seq=None), math.nan
        if cmd is None and not self.body.motors_on_bus:
            self.unanswered += 1
            if lockstep and self.unanswered in (1, 10, 100):
                log.warning("tick %d: no answer from the node", self.k)
        return cmd, rtt

    def _await_answer(self) -> MotorCommand | None:
        deadline = time.monotonic() + self.cfg.lockstep_timeout_s
        while True:
            cmd = self.port.take_command(min(self.cfg.retry_s, max(0.0, deadline - time.monotonic())),
                                         want_seq=self.k)
            if cmd is not None or time.monotonic() >= deadline:
                return cmd
            self.retransmits += 1
            torso, fb = self._sent
            self.port.publish_tick(torso, None, None, fb)  # the tick again, as sent (rtt from the first)

    def run_lockstep(self, n_ticks: int, stop: Callable[[], bool] | None = None) -> None:
        for _ in range(n_ticks):
            if stop is not None and stop():
                break
            self.tick(lockstep=True)

    def run_realtime(self, n_ticks: int, stop: Callable[[], bool] | None = None) -> float:
        """Step on a wall clock at 1/dt, applying the newest command; returns the achieved rate (Hz)."""
        clock = RealTimeClock(1.0 / self.dt)
        t0 = time.monotonic()
        k0 = self.k
        for _ in range(n_ticks):
            if stop is not None and stop():
                break
            wall = clock.wait()
            self.publish_tick(wall_now=wall)
            self.finish_tick(self.port.take_command(0.0, want_seq=None))
        elapsed = time.monotonic() - t0
        return (self.k - k0) / elapsed if elapsed > 0 else 0.0

    def wait_for_node(self, timeout_s: float = 30.0) -> bool:
        """Block (wall time) until a node heartbeat arrives, so tick 0 is not published into the void."""
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            hbs = self.port.node_heartbeats()
            if hbs:
                self.watchdog.reset_count = max(h.reset_count for h in hbs)
                return True
            time.sleep(0.01)
        return False
