"""The stand-in robot: the pybullet bench spine speaking the robot's side of the spine interface.

Per 1 ms tick the robot publishes the torso state (q1 of the bench clamp), its heartbeat (every
`heartbeat_period_s`), the torso computer's spine command (every `command_period_s`, from a script) and
last the motor feedback (with the bench's load-cell reading of F_x in `load_cell[0]`); it then applies
the newest motor command and steps the world with the script's push force.

- lockstep: it waits for the command that answers this tick's feedback, so the co-simulation is
  deterministic whatever the machine's speed (time = ticks x 1 ms);
- real time: it steps on its own 1 kHz clock and applies whatever command is newest.

With no fresh motor command for `command_timeout_s` (20 ms) the motors apply zero torque (a CyberGear's
CAN timeout, which the real robot should enable). Like SPARC's PMU it watches the node's heartbeat: when
it is older than `heartbeat_deadline_s` the robot latches a fault and applies zero torque until the
node's heartbeat shows a higher `reset_count`.

The same `BenchRobot` drives an in-process link (`InProcessRobotPort`) or LCM (`LcmRobotPort`), so an
in-process run and a run over LCM differ only in transport.
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import lcm
import numpy as np

from sparc_quad.bench.static import StaticConfig, push_pull
from sparc_quad.bench.stats import ols
from sparc_quad.sim.bench_world import BenchWorld
from sparc_quad.sim.plant import PlantConfig
from spine_module import params as P
from spine_module.buses.base import MotorCommand, MotorFeedback
from spine_module.buses.inprocess import InProcessBus, InProcessLink
from spine_module.messages import (
    Heartbeat,
    MessageError,
    Mode,
    SpineCommand,
    SpineState,
    TorsoState,
    channels,
    codec,
)
from spine_module.node import Controllers, NodeConfig, SpineNode
from spine_module.node.clocks import RealTimeClock
from spine_module.node.io import InProcessNodeIO

log = logging.getLogger("sparc_quad.bench_robot")

# external force along x (N) as a function of (time s, true task pose, true task velocity)
ForceLaw = Callable[[float, np.ndarray, np.ndarray], float]


# --- scripts ------------------------------------------------------------------------------------------
@dataclass
class BenchScript:
    """What the rig and the torso computer do: the spine command to send and the push on the end effector."""

    command: SpineCommand | None = None
    force: ForceLaw | None = None
    duration_s: float = 1.0


def hold_script(duration_s: float = 1.0, k: tuple[float, float, float] = tuple(P.K_DEFAULT),
                d: tuple[float, float, float] = tuple(P.D_DEFAULT)) -> BenchScript:
    cmd = SpineCommand(mode=Mode.IMPEDANCE, k=np.array(k, dtype=float), d=np.array(d, dtype=float))
    return BenchScript(command=cmd, duration_s=duration_s)


_STATIC = StaticConfig()


def static_push_script(k_x: float = 500.0, amplitude_m: float = _STATIC.amplitude_m,
                       period_s: float = _STATIC.period_s, cycles: float = 1.0, k_z: float = _STATIC.k_z,
                       k_theta: float = _STATIC.k_theta,
                       d: tuple[float, float, float] = _STATIC.d) -> BenchScript:
    """Section IV-A's push-pull, the same force law as `sparc-quad bench static`."""
    force = push_pull(k_x * amplitude_m, period_s)
    cmd = SpineCommand(mode=Mode.IMPEDANCE, k=np.array([k_x, k_z, k_theta]), d=np.array(d, dtype=float))
    return BenchScript(command=cmd, force=force, duration_s=cycles * period_s)


# --- robot-side ports ---------------------------------------------------------------------------------
class RobotPort:
    """The robot's end of the interface."""

    def publish_torso(self, t: TorsoState) -> None: ...
    def publish_heartbeat(self, h: Heartbeat) -> None: ...
    def publish_command(self, c: SpineCommand) -> None: ...
    def publish_feedback(self, fb: MotorFeedback) -> None: ...

    def take_command(self, timeout_s: float, want_seq: int | None) -> MotorCommand | None:
        """Newest motor command; with `want_seq`, wait (up to timeout) for the one answering that feedback."""
        raise NotImplementedError

    def node_heartbeats(self) -> list[Heartbeat]:
        return []

    def close(self) -> None:
        pass


class InProcessRobotPort(RobotPort):
    def __init__(self, link: InProcessLink, node_io: InProcessNodeIO) -> None:
        self.link, self.io = link, node_io
        self._hb_read = 0

    def publish_torso(self, t: TorsoState) -> None:
        self.io.send_torso(t)

    def publish_heartbeat(self, h: Heartbeat) -> None:
        self.io.send_heartbeat(h)

    def publish_command(self, c: SpineCommand) -> None:
        self.io.send_command(c)

    def publish_feedback(self, fb: MotorFeedback) -> None:
        # through the codec, as on the wire: identical numbers to the LCM path
        data = codec.encode_motor_feedback(fb)
        self.link.robot.publish_feedback(codec.decode_motor_feedback(data))

    def take_command(self, timeout_s: float, want_seq: int | None) -> MotorCommand | None:
        got = self.link.robot.take_command(timeout_s)
        if got is None:
            return None
        cmd, answers = got
        data = codec.encode_motor_command(cmd, answers)
        cmd, answers = codec.decode_motor_command(data)
        if want_seq is not None and answers != want_seq:
            return None
        return cmd

    def node_heartbeats(self) -> list[Heartbeat]:
        hbs = list(self.io.heartbeats)
        self.io.heartbeats.clear()
        return hbs


class LcmRobotPort(RobotPort):
    """Robot side over LCM. Spine states from the node are kept in `states` when `keep_states`."""

    def __init__(self, url: str = "", lc: lcm.LCM | None = None, keep_states: bool = True) -> None:
        self.lc = lc if lc is not None else lcm.LCM(url)
        self._cmd: tuple[MotorCommand, int] | None = None
        self._hbs: list[Heartbeat] = []
        self.states: list[SpineState] = []
        self.keep_states = keep_states
        self.rejected = 0
        self._subs = [self.lc.subscribe(channels.MOTOR_COMMAND, self._on_command),
                      self.lc.subscribe(channels.HEARTBEAT_NODE, self._on_heartbeat)]
        if keep_states:
            self._subs.append(self.lc.subscribe(channels.SPINE_STATE, self._on_state))

    def _on_command(self, channel: str, data: bytes) -> None:
        try:
            self._cmd = codec.decode_motor_command(data, channel)
        except MessageError as exc:
            self.rejected += 1
            log.warning("rejected %s", exc)

    def _on_heartbeat(self, channel: str, data: bytes) -> None:
        try:
            self._hbs.append(codec.decode_heartbeat(data, channel))
        except MessageError as exc:
            self.rejected += 1
            log.warning("rejected %s", exc)

    def _on_state(self, channel: str, data: bytes) -> None:
        try:
            self.states.append(codec.decode_state(data, channel))
        except (MessageError, ValueError) as exc:
            self.rejected += 1
            log.warning("rejected %s", exc)

    def publish_torso(self, t: TorsoState) -> None:
        self.lc.publish(channels.TORSO_STATE, codec.encode_torso(t))

    def publish_heartbeat(self, h: Heartbeat) -> None:
        self.lc.publish(channels.HEARTBEAT_ROBOT, codec.encode_heartbeat(h))

    def publish_command(self, c: SpineCommand) -> None:
        self.lc.publish(channels.SPINE_COMMAND, codec.encode_command(c))

    def publish_feedback(self, fb: MotorFeedback) -> None:
        self.lc.publish(channels.MOTOR_FEEDBACK, codec.encode_motor_feedback(fb))

    def take_command(self, timeout_s: float, want_seq: int | None) -> MotorCommand | None:
        deadline = time.monotonic() + timeout_s
        while True:
            if self._cmd is not None and (want_seq is None or self._cmd[1] == want_seq):
                cmd, self._cmd = self._cmd[0], None
                return cmd
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                while self.lc.handle_timeout(0) > 0:
                    pass
                if self._cmd is not None and (want_seq is None or self._cmd[1] == want_seq):
                    continue
                return None
            self.lc.handle_timeout(max(1, int(remaining * 1000)))

    def node_heartbeats(self) -> list[Heartbeat]:
        while self.lc.handle_timeout(0) > 0:
            pass
        hbs, self._hbs = self._hbs, []
        return hbs

    def close(self) -> None:
        for s in self._subs:
            self.lc.unsubscribe(s)
        self._subs = []


# --- the robot ----------------------------------------------------------------------------------------
@dataclass
class RobotConfig:
    heartbeat_period_s: float = 0.010
    heartbeat_deadline_s: float = P.SAFETY.heartbeat_deadline_s
    command_period_s: float = 0.010  # spine command from the script, sim time
    lockstep_timeout_s: float = 2.0  # wall time to wait for the node's answer before giving up on a tick
    # Motor-side command timeout (the CyberGear's CAN timeout, off by default on the real motor): with no
    # fresh command for this long the motors apply zero torque instead of holding a stale one. Robot clock.
    command_timeout_s: float = 0.020
    retry_s: float = 0.2  # lockstep: resend the tick when its answer has not come within this (wall s)
    name: str = "bench-robot"


@dataclass
class BenchLog:
    """Per tick: time s, true q1..q4 rad, true task pose, applied F_x N, load-cell reading N, applied
    torque N*m, whether the robot had a command for the tick, robot-side latched fault; in lockstep the
    wall round trip from publishing the tick to receiving its answer, s (NaN otherwise)."""

    t: list[float] = field(default_factory=list)
    q: list[np.ndarray] = field(default_factory=list)
    x: list[np.ndarray] = field(default_factory=list)
    f_true: list[float] = field(default_factory=list)
    f_cell: list[float] = field(default_factory=list)
    tau: list[np.ndarray] = field(default_factory=list)
    answered: list[bool] = field(default_factory=list)
    latched: list[bool] = field(default_factory=list)
    rtt_s: list[float] = field(default_factory=list)

    def arrays(self) -> dict[str, np.ndarray]:
        return {k: np.array(v) for k, v in self.__dict__.items()}


class BenchRobot:
    def __init__(self, world: BenchWorld, port: RobotPort, script: BenchScript | None = None,
                 config: RobotConfig | None = None) -> None:
        self.world, self.port = world, port
        self.script = script if script is not None else BenchScript()
        self.cfg = config if config is not None else RobotConfig()
        self.k = 0  # tick
        self.log = BenchLog()
        self._kin = world.model.create_data()
        self._cmd_seq = 0
        self._hb_seq = 0
        self.last_cmd: MotorCommand | None = None
        self.latched = False
        self._node_hb_t: float | None = None
        self._node_reset_count = 0
        self._latched_at_reset_count = 0
        self.unanswered = 0
        self.retransmits = 0
        self._sent: tuple[TorsoState, MotorFeedback] | None = None
        self.t_feedback_wall = 0.0
        self._clock = 0.0
        self._cmd_clock: float | None = None

    @property
    def dt(self) -> float:
        return self.world.dt_s

    def now(self) -> float:
        """Robot time of the current tick, s (exact in microseconds, as on the wire)."""
        return self.k * round(self.dt * 1e6) * 1e-6

    def publish_tick(self, wall_now: float | None = None) -> float:
        """Publish torso state, heartbeat and command (when due), then the motor feedback of this tick."""
        t = self.now()
        clock = t if wall_now is None else wall_now
        st = self.world.state()
        hb_every = max(1, round(self.cfg.heartbeat_period_s / self.dt))
        cmd_every = max(1, round(self.cfg.command_period_s / self.dt))
        torso = TorsoState(q1=float(st.q[0]), dq1=float(st.dq[0]), stamp_s=t, seq=self.k)
        self.port.publish_torso(torso)
        if self.k % hb_every == 0:
            self.port.publish_heartbeat(Heartbeat(sender=self.cfg.name, fault=self.latched, stamp_s=t,
                                                  seq=self._hb_seq))
            self._hb_seq += 1
        if self.script.command is not None and self.k % cmd_every == 0:
            c = self.script.command
            c.stamp_s, c.seq = t, self._cmd_seq
            self.port.publish_command(c)
            self._cmd_seq += 1
        # like rig.run: the motors' frame, then the rig's force and its load cell (same rng order)
        fb = self.world.feedback()
        # a CyberGear feedback frame cannot carry more than its encoding range
        fb.q = np.clip(fb.q, -4 * math.pi, 4 * math.pi)
        fb.dq = np.clip(fb.dq, -P.VELOCITY_LIMIT_RAD_S, P.VELOCITY_LIMIT_RAD_S)
        fb.tau = np.clip(fb.tau, -P.TORQUE_LIMIT_NM, P.TORQUE_LIMIT_NM)
        self.world.model.update_kinematics(self._kin, st.q, st.dq)
        fx = self.script.force(self.world.time_s, self._kin.x, self._kin.dx) if self.script.force else 0.0
        f_cell = self.world.load_cell(fx)
        fb.load_cell_n = np.array([f_cell, np.nan])
        fb.stamp_s, fb.seq = t, self.k
        self.t_feedback_wall = time.perf_counter()
        self.port.publish_feedback(fb)
        self._sent = (torso, fb)
        self._pending = (t, st.q.copy(), self._kin.x.copy(), fx, f_cell)
        self._clock = clock
        self._watch_node(clock)
        return t

    def _watch_node(self, clock: float) -> None:
        for hb in self.port.node_heartbeats():
            self._node_hb_t = clock
            self._node_reset_count = max(self._node_reset_count, hb.reset_count)
        fresh = self._node_hb_t is not None and clock - self._node_hb_t <= self.cfg.heartbeat_deadline_s
        if self.latched and fresh and self._node_reset_count > self._latched_at_reset_count:
            self.latched = False
            log.warning("t=%.4f s: node heartbeat back and reset requested: fault cleared", clock)
        if (not self.latched and self._node_hb_t is not None
                and clock - self._node_hb_t > self.cfg.heartbeat_deadline_s):
            self.latched = True
            self._latched_at_reset_count = self._node_reset_count
            log.warning("t=%.4f s: node heartbeat lost (%.1f ms): fault latched, zero torque", clock,
                        1e3 * (clock - self._node_hb_t))

    def finish_tick(self, cmd: MotorCommand | None, rtt_s: float = math.nan) -> None:
        """Apply `cmd` (None: keep the last one, as a motor does) and step the world by one tick."""
        t, q, x, fx, f_cell = self._pending
        if cmd is not None:
            self.last_cmd = cmd
            self._cmd_clock = self._clock
        tau = np.zeros(3)
        c = self.last_cmd
        timed_out = self._cmd_clock is None or self._clock - self._cmd_clock > self.cfg.command_timeout_s
        if c is not None and c.enable and not self.latched and not timed_out:
            fb_q, fb_dq = q[1:], self.world.state().dq[1:]
            tau = c.torque(fb_q, fb_dq)
        f_ext = np.array([fx, 0.0, 0.0]) if fx != 0.0 else None
        self.world.step(tau, f_ext)
        lg = self.log
        lg.t.append(t)
        lg.q.append(q)
        lg.x.append(x)
        lg.f_true.append(fx)
        lg.f_cell.append(f_cell)
        lg.tau.append(self.world.last_applied.copy())
        lg.answered.append(cmd is not None)
        lg.latched.append(self.latched)
        lg.rtt_s.append(rtt_s)
        self.k += 1

    def wait_for_node(self, timeout_s: float = 30.0) -> bool:
        """Block (wall time) until a node heartbeat arrives, so tick 0 is not published into the void."""
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            hbs = self.port.node_heartbeats()
            if hbs:
                self._node_reset_count = max(h.reset_count for h in hbs)
                return True
            time.sleep(0.01)
        return False

    def run_lockstep(self, n_ticks: int | None = None, stop: Callable[[], bool] | None = None) -> None:
        """Publish, wait for the node's answer to this tick, apply, step; `n_ticks` or the script's length."""
        n = n_ticks if n_ticks is not None else round(self.script.duration_s / self.dt)
        for _ in range(n):
            if stop is not None and stop():
                break
            self.publish_tick()
            cmd = self._await_answer()
            rtt = time.perf_counter() - self.t_feedback_wall  # feedback out -> its answer in
            if cmd is None:
                self.unanswered += 1
                if self.unanswered in (1, 10, 100):
                    log.warning("tick %d: no answer from the node within %.1f s", self.k,
                                self.cfg.lockstep_timeout_s)
            self.finish_tick(cmd, rtt)

    def _await_answer(self) -> MotorCommand | None:
        """Wait for the command answering this tick; UDP may drop a datagram, so every `retry_s` the
        tick's torso state and feedback are sent again (the node answers a repeated tick with its
        previous command, without stepping again)."""
        deadline = time.monotonic() + self.cfg.lockstep_timeout_s
        while True:
            cmd = self.port.take_command(min(self.cfg.retry_s, max(0.0, deadline - time.monotonic())),
                                         want_seq=self.k)
            if cmd is not None or time.monotonic() >= deadline:
                return cmd
            self.retransmits += 1
            torso, fb = self._sent
            self.port.publish_torso(torso)
            self.port.publish_feedback(fb)

    def run_realtime(self, n_ticks: int | None = None, stop: Callable[[], bool] | None = None) -> float:
        """Step on a 1 kHz wall clock, applying the newest command; returns the achieved rate (Hz)."""
        n = n_ticks if n_ticks is not None else round(self.script.duration_s / self.dt)
        clock = RealTimeClock(1.0 / self.dt)
        t0 = time.monotonic()
        for _ in range(n):
            if stop is not None and stop():
                break
            wall = clock.wait()
            self.publish_tick(wall_now=wall)
            self.finish_tick(self.port.take_command(0.0, want_seq=None))
        elapsed = time.monotonic() - t0
        return self.k / elapsed if elapsed > 0 else 0.0


def run_inprocess(script: BenchScript, node_config: NodeConfig | None = None,
                  plant: PlantConfig | None = None, seed: int = 0, controllers: Controllers | None = None,
                  n_ticks: int | None = None,
                  robot_config: RobotConfig | None = None) -> tuple[BenchRobot, list[SpineState]]:
    """Node and bench robot in one process, in lockstep: the reference for the LCM runs."""
    link, io = InProcessLink(), InProcessNodeIO()
    ctrls = controllers if controllers is not None else Controllers.default()
    node = SpineNode(ctrls, InProcessBus(link), io, node_config)
    with BenchWorld(plant=plant, seed=seed) as world:
        robot = BenchRobot(world, InProcessRobotPort(link, io), script, robot_config)
        n = n_ticks if n_ticks is not None else round(script.duration_s / world.dt_s)
        for _ in range(n):
            t = robot.publish_tick()
            node.tick(t, node.receive(0.0))
            robot.finish_tick(robot.port.take_command(0.0, want_seq=robot.k))
        node.stop()
    return robot, list(io.states)


def states_arrays(states: list[SpineState]) -> dict[str, np.ndarray]:
    """Spine states as arrays (one row per state), for saving and analysis."""
    keys = ("stamp_s", "seq", "mode", "faults", "q", "dq", "tau_cmd", "tau_est", "x", "dx", "gain_scale",
            "load_cell", "period", "jitter_max", "compute", "feedback_seq")
    return {f"node_{k}": np.array([np.asarray(getattr(s, k), dtype=float) for s in states]) for k in keys}


def stiffness_from_states(states: list[SpineState] | dict[str, np.ndarray], x_d: float = P.X_EQUILIBRIUM[0],
                          skip_s: float = 0.0) -> float:
    """OLS slope of the load-cell force against the node's x (encoders + forward kinematics), N/m."""
    a = states if isinstance(states, dict) else states_arrays(states)
    t, x, f = a["node_stamp_s"], a["node_x"][:, 0] - x_d, a["node_load_cell"][:, 0]
    sel = (t >= skip_s) & np.isfinite(x) & np.isfinite(f)
    return ols(x[sel], f[sel]).slope
