"""The spine node: bus -> state -> controller -> safety -> bus, once per tick.

One `SpineNode` object runs between any `MotorBus` (in-process simulation, LCM to a simulated robot,
CyberGear CAN) and any `NodeIO` (LCM or in-process), like Cheetah-Software's one RobotRunner between a
SimulationBridge and a HardwareBridge. `run_realtime` drives it from a fixed-rate clock, `run_lockstep`
from the motor feedback ticks.

Time: every deadline is measured on the node's own clock (`now`, s) from when an input *arrived*, never
from the sender's stamp, so clock offsets between computers do not matter. In real time `now` is the
monotonic clock since start; in lockstep it is the stamp of the feedback tick being answered.
"""

from __future__ import annotations

import logging
import math
import secrets
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field, fields
from functools import partial

import numpy as np

from spine_module import params, safety
from spine_module.buses.base import MotorBus, MotorBusError, MotorCommand, MotorFeedback
from spine_module.control.gain_limits import unstable_gains
from spine_module.messages import Fault, Heartbeat, MessageError, Mode, SpineCommand, SpineState, TorsoState
from spine_module.messages import channels as ch
from spine_module.messages.types import MODES
from spine_module.node.clocks import PeriodStats, RealTimeClock
from spine_module.node.controllers import Controllers
from spine_module.node.io import NodeIO, opening_inputs_in

log = logging.getLogger("spine_module.node")

_BAD_COMMAND = int(Fault.BAD_COMMAND)
_tuple_new = tuple.__new__  # NamedTuple records without their Python-level __new__ (1 kHz path)
_ZEROS3 = np.zeros(3)  # q_des, dq_des, kp, kd of the node's torque-only commands: shared, so read-only
_ZEROS3.flags.writeable = False
_BAD_BY_CHANNEL = {ch.TORSO_STATE: int(Fault.BAD_TORSO), ch.SPINE_COMMAND: _BAD_COMMAND,
                   ch.HEARTBEAT_ROBOT: _BAD_COMMAND, ch.MOTOR_FEEDBACK: int(Fault.BAD_FEEDBACK)}
_NOISY = Fault.TORQUE_CLAMPED | Fault.JOINT_LIMIT
_NOISY_BITS = int(_NOISY)
_MOTOR, _CONTROLLER, _BUS = int(Fault.MOTOR), int(Fault.CONTROLLER), int(Fault.BUS)
_NODE_CONFLICT = int(Fault.NODE_CONFLICT)
_GAIN_MODES = frozenset((Mode.IMPEDANCE, Mode.PD))  # commands whose k and d the law renders
_JOINT_LIMIT, _TORQUE_CLAMPED = int(Fault.JOINT_LIMIT), int(Fault.TORQUE_CLAMPED)
_IMPEDANCE, _PD = int(Mode.IMPEDANCE), int(Mode.PD)
_DAMPING, _JOINT_TORQUE = int(Mode.DAMPING), int(Mode.JOINT_TORQUE)
_MODE_DISABLED = Mode.DISABLED
# the 1 kHz path's globals bound once, and its constant arrays (copied, never handed out)
_perf_counter, _isfinite = time.perf_counter, math.isfinite
_supervise_values, _limit_torque, _Receipts = safety.supervise_values, safety.limit_torque, safety.Receipts
_ndarray, _F64 = np.ndarray, np.dtype(np.float64)
_ZERO_FLOATS3 = (0.0, 0.0, 0.0)
_NAN3, _NAN2 = np.full(3, np.nan), np.full(2, np.nan)
# the tick builds SpineState positionally (keywords cost ~1 us a tick): in this order
_STATE_FIELDS = ("stamp_s", "seq", "mode", "requested_mode", "faults", "rejected", "q", "dq", "tau_cmd",
                 "tau_est", "x", "dx", "gain_scale", "load_cell", "temperature", "period", "jitter_max",
                 "compute", "feedback_seq", "command_seq", "torso_seq")
if tuple(f.name for f in fields(SpineState)) != _STATE_FIELDS:
    raise ImportError(f"SpineState's fields changed order: {[f.name for f in fields(SpineState)]}; update "
                      "runner._STATE_FIELDS and SpineNode.tick")


@dataclass
class NodeConfig:
    rate_hz: float = params.CONTROL_RATE_HZ
    safety: safety.SafetyConfig = field(default_factory=safety.SafetyConfig)
    heartbeat_period_s: float = params.HEARTBEAT_PERIOD_S  # node -> robot heartbeat, node's clock
    state_every: int = 1  # publish spine state every N ticks
    name: str = "spine-node"
    jitter_window: int = 1000
    bad_hold_s: float = 0.1  # a BAD_* fault bit stays set this long after the last rejected message
    # drawn once per node: its heartbeats carry it, so two nodes on one URL tell each other apart (never 0)
    instance: int = field(default_factory=lambda: secrets.randbits(62) | 1)


class _RateLimitedLog:
    def __init__(self, every_s: float = 1.0) -> None:
        self.every = every_s
        self._last: dict[str, float] = {}

    def __call__(self, key: str, now: float, level: int, msg: str, *args: object) -> None:
        last = self._last.get(key)
        if last is None or now - last >= self.every or now < last:
            self._last[key] = now
            log.log(level, msg, *args)


class SpineNode:
    def __init__(self, controllers: Controllers, bus: MotorBus, io: NodeIO,
                 config: NodeConfig | None = None) -> None:
        self.ctrl = controllers
        self.bus = bus
        self.io = io
        self.cfg = config if config is not None else NodeConfig()
        io.instance = self.cfg.instance
        io.inbox.decode_commands_for(controllers.spine)  # targets judged by the model it runs
        # safety state as plain values (`safety.supervise_values`); the `safety` property shows it as a
        # SafetyState
        self._sv = safety.Supervised()
        self._rx_torso: float | None = None  # when each input last arrived (valid), node time, s
        self._rx_feedback: float | None = None
        self._rx_command: float | None = None
        self._rx_heartbeat: float | None = None
        self.fb: MotorFeedback | None = None
        self._fb_q: list[float] = []  # the accepted feedback's q, dq as floats, and whether a motor faults
        self._fb_dq: list[float] = []
        self._fb_motor_fault = False
        self.torso: TorsoState | None = None
        self.command: SpineCommand | None = None
        self._bad_until: dict[int, float] = {}  # BAD_* bit -> node time it is shown until
        self.rejected = ""
        self.rejected_count = 0
        self.seq = 0
        self.stats = PeriodStats(1.0 / self.cfg.rate_hz, self.cfg.jitter_window)
        self.state = SpineState()
        self._hb_seq = 0
        self._hb_next: float | None = None
        self._last_faults = 0
        self._pending_bus_fault = 0
        self._ratelog = _RateLimitedLog()
        self.last_now: float | None = None
        self.last_command: MotorCommand | None = None
        self.repeated_ticks = 0
        self.lockstep_torso_missing = 0  # lockstep ticks run without their own torso state (run_lockstep)
        self.lockstep_opening_incomplete = False  # first lockstep tick ran without torso/heartbeat/command
        self.tick_errors = 0
        self._ramp_key: float | None = None  # ramp start time the ramp origin below belongs to
        self._ramp_from: np.ndarray | None = None
        self._set_ctrl: object | None = None  # controller whose gains and target were last set, and from what
        self._set_for: tuple = ()
        self._limits = safety.TorqueLimits.from_config(self.cfg.safety)  # the output stage's numbers
        self._polled_at: float | None = None  # node time the inputs were last polled (tick or start-up drain)
        self._law_clamped = False  # this tick's controller clamped a torque itself
        self.stalls = 0  # ticks after a gap longer than the feedback deadline (their inputs drained, stale)
        self.drained_at_start = 0  # inputs queued before the first tick, dropped unused

    @property
    def safety(self) -> safety.SafetyState:
        """The watchdogs' and latches' state after the last tick."""
        v = self._sv
        return safety.SafetyState(latched=Fault(v.latched), heartbeat_seen=v.heartbeat_seen,
                                  mode=MODES[v.mode], ramp_t0=v.ramp_t0, stale_since=v.stale_since,
                                  reset_count=v.reset_count)

    @property
    def rx(self) -> safety.Receipts:
        """When each input last arrived (valid), node time, s; None if never."""
        return safety.Receipts(torso=self._rx_torso, feedback=self._rx_feedback, command=self._rx_command,
                               heartbeat=self._rx_heartbeat)

    # --- inputs -----------------------------------------------------------------------------------
    def receive(self, timeout_s: float | None) -> MotorFeedback | None:
        """Newest feedback from the bus (None if none); bus and decode errors become fault bits."""
        try:
            return self.bus.receive(timeout_s)
        except MotorBusError as exc:
            self._bus_error(exc, self.last_now if self.last_now is not None else 0.0)
            return None

    def _bus_error(self, exc: MotorBusError, now: float) -> None:
        if isinstance(exc.__cause__, MessageError):
            self._flag_bad(Fault.BAD_FEEDBACK, now)
            self.rejected = str(exc.__cause__)
            self.rejected_count += 1
            self._ratelog(f"reject:{exc.__cause__.channel}.{exc.__cause__.field}", now, logging.WARNING,
                          "rejected %s", exc.__cause__)
        else:
            self._pending_bus_fault |= _BUS
            self._ratelog("bus", now, logging.ERROR, "motor bus error: %s", exc)

    def _accept_feedback(self, fb: MotorFeedback, now: float) -> None:
        try:  # numpy feedback (every bus): three tolists and nine isfinite calls (no temporary list)
            q, dq, tau = fb.q.tolist(), fb.dq.tolist(), fb.tau.tolist()
            f = _isfinite
            if not (len(q) == 3 and len(dq) == 3 and len(tau) == 3 and f(q[0]) and f(q[1]) and f(q[2])
                    and f(dq[0]) and f(dq[1]) and f(dq[2]) and f(tau[0]) and f(tau[1]) and f(tau[2])):
                q = None
        except (AttributeError, TypeError):  # lists, tuples, nested arrays: one by one
            q, dq = _finite3(fb.q), _finite3(fb.dq)
            if _finite3(fb.tau) is None:
                q = None
        if q is None or dq is None:
            self._flag_bad(Fault.BAD_FEEDBACK, now)
            self.rejected = f"{ch.MOTOR_FEEDBACK}: non-finite or mis-shaped q/dq/tau"
            self.rejected_count += 1
            self._ratelog("reject:feedback", now, logging.WARNING, "rejected %s", self.rejected)
            return
        self.fb = fb
        self._fb_q, self._fb_dq = q, dq
        fault = fb.fault
        self._fb_motor_fault = any((fault if type(fault) is _ndarray else np.asarray(fault)).tolist())
        self._rx_feedback = now

    def _flag_bad(self, bit: Fault | int, now: float) -> None:
        self._bad_until[int(bit)] = now + self.cfg.bad_hold_s

    def drain_inputs(self, now: float) -> int:
        """Before the first real-time tick: drop everything queued since the transport opened (torso states,
        commands and feedback up to seconds old at start-up); the node then hears only what arrives from
        `now` on. Returns how many messages were dropped (also in `drained_at_start`)."""
        io = self.io
        io.drain()
        io.inbox.take()
        dropped = io.inbox.received  # no tick has looked at any: every input so far is dropped
        while True:  # newest-wins buses keep one feedback; a queue (LCM) may hold many
            try:
                fb = self.bus.receive(0.0)
            except MotorBusError:
                break
            if fb is None:
                break
            dropped += 1
        self._polled_at = now
        self.drained_at_start = dropped
        return dropped

    def _poll_inputs(self, now: float) -> float:
        """Poll the inputs; returns the start of the gap since the last poll. After a gap longer than
        the feedback deadline (a stalled node, a late tick) everything queued is drained and an input taken
        now may have waited the whole gap: it counts as arrived at the gap's start, so an input whose
        deadline is shorter than the gap raises its stale fault this tick instead of being used as fresh."""
        prev = self._polled_at
        self._polled_at = now
        if prev is None or now - prev - safety.EPS_S <= self.cfg.safety.feedback_deadline_s:
            self.io.poll()
            return now
        self.io.drain()
        self.stalls += 1
        return prev

    @staticmethod
    def _arrived(now: float, gap_start: float, deadline_s: float) -> float:
        return now if now - gap_start - safety.EPS_S <= deadline_s else gap_start

    # --- one tick -----------------------------------------------------------------------------------
    def tick(self, now: float, feedback: MotorFeedback | None, wall_s: float | None = None) -> SpineState:
        """Run one control step at node time `now` with the feedback received for it (None: none new).

        Returns a new SpineState (callers may keep it; nothing in it is reused by a later tick)."""
        t_start = _perf_counter()
        stats = self.stats
        stats.mark(time.monotonic() if wall_s is None else wall_s)
        self.last_now = now
        cfg = self.cfg
        scfg = cfg.safety
        io = self.io
        gap_start = self._poll_inputs(now)
        arrived = self._arrived
        if feedback is not None:
            self._accept_feedback(feedback, arrived(now, gap_start, scfg.feedback_deadline_s))
        torso, command, heartbeat, reset, rejects = io.inbox.take()
        for rej in rejects:
            self._flag_bad(_BAD_BY_CHANNEL.get(rej.channel, _BAD_COMMAND), now)
            self.rejected = str(rej)
            self.rejected_count += 1
            self._ratelog(f"reject:{rej.channel}.{rej.field}", now, logging.WARNING, "rejected %s", rej)
        if torso is not None:
            self.torso = torso
            self._rx_torso = arrived(now, gap_start, scfg.torso_deadline_s)
        if command is not None and command.mode in _GAIN_MODES:
            why = unstable_gains(command.k, command.d, cfg.rate_hz)
            if why is not None:  # a loop that would chatter at full torque: refused, the last command stays
                self._flag_bad(_BAD_COMMAND, now)
                self.rejected = f"{ch.SPINE_COMMAND}.k/d: {why}"
                self.rejected_count += 1
                self._ratelog("reject:gains", now, logging.WARNING, "rejected %s", self.rejected)
                command = None
        if command is not None:
            self.command = command
            self._rx_command = arrived(now, gap_start, scfg.command_deadline_s)
        if heartbeat is not None:
            self._rx_heartbeat = arrived(now, gap_start, scfg.heartbeat_deadline_s)

        command = self.command
        requested = command.mode if command is not None else _MODE_DISABLED
        if io.peers and not self._sv.latched & _NODE_CONFLICT:  # another node commands these motors too
            self._sv = self._sv._replace(latched=self._sv.latched | _NODE_CONFLICT)
        self._sv = sv = _supervise_values(
            self._sv, now, _tuple_new(_Receipts, (self._rx_torso, self._rx_feedback, self._rx_command,
                                                  self._rx_heartbeat)), int(requested), reset, cfg.safety)
        mode_i, faults, scale, default_gains, enable = sv.mode, sv.faults, sv.gain_scale, sv.default_gains, \
            sv.enable
        mode = MODES[mode_i]
        # fault bits as a plain int inside the tick (IntFlag arithmetic costs ~1 us per operation)
        bus_fault = self._pending_bus_fault  # the bus refused this tick's feedback: zero torque this tick
        if bus_fault:
            faults |= bus_fault
            self._pending_bus_fault = 0
        if self._bad_until:
            for bit, until in self._bad_until.items():
                if now <= until:
                    faults |= bit

        # joint state as plain floats: three numbers per tick are cheaper than numpy temporaries
        torso, fb = self.torso, self.fb
        q1, dq1 = (torso.q1, torso.dq1) if torso is not None else (0.0, 0.0)
        if fb is not None:
            fq, fdq = self._fb_q, self._fb_dq
            if self._fb_motor_fault:
                faults |= _MOTOR
        else:
            fq = fdq = _ZERO_FLOATS3
        q, dq = np.array((q1, *fq)), np.array((dq1, *fdq))
        x = dx = None
        # the output stage (joint-limit damping, clamp) acts on every torque a mode commands; the others
        # (disabled, E-stop, a failed controller) send zeros
        limited = True
        if mode_i == _IMPEDANCE or mode_i == _PD:
            self._law_clamped = False
            tau_l, x, dx, ok = self._control(mode_i, scale, default_gains, q, dq)
            if self._law_clamped:
                faults |= _TORQUE_CLAMPED
            if not ok:
                faults |= _CONTROLLER
                limited = False
            elif scale == 0.0:  # the first tick of a soft start (start-up, after a latch or a stale spell)
                # commands zero torque, gravity and feed-forward included; K and D then ramp from 0. (Ramping
                # the whole law instead let the bench spine sag and whip to 30 rad/s over CAN: not done.)
                tau_l = [0.0, 0.0, 0.0]
        else:
            if fb is not None and math.isfinite(q1) and math.isfinite(dq1):
                x, dx = self.ctrl.task_state(q, dq)
            if mode_i == _JOINT_TORQUE:
                tau_l = np.asarray(command.tau_ff, dtype=float).tolist()
            elif mode_i == _DAMPING:
                tau_l = safety.damping_torque(fdq, cfg.safety.damping_mode)
            else:
                limited = False
        if limited:
            a, b, c, near, clamped = _limit_torque(tau_l, fq, fdq, self._limits)
            if near:
                faults |= _JOINT_LIMIT
            if clamped:
                faults |= _TORQUE_CLAMPED
            tau = np.array((a, b, c)) if enable and not bus_fault else np.zeros(3)
        else:
            tau = np.zeros(3)
        if x is None:
            x = _NAN3.copy()
            dx = _NAN3.copy()

        cmd = MotorCommand(tau, _ZEROS3, _ZEROS3, _ZEROS3, _ZEROS3, enable, now, self.seq)  # torque-only
        self.last_command = cmd
        try:
            self.bus.send(cmd)
        except MotorBusError as exc:
            self._bus_error(exc, now)
            faults |= _BUS

        hb_next = self._hb_next
        period = cfg.heartbeat_period_s
        if hb_next is None or now >= hb_next or now < hb_next - 10 * period:
            # on its own schedule (next = previous slot + period), not "a period after the tick that sent
            # it": late ticks then do not stretch every period (90-95 Hz measured instead of 100); a node far
            # behind (or a clock that went back) starts a new schedule from now
            self._hb_next = (now + period if hb_next is None or now >= hb_next + period
                             or now < hb_next - 10 * period else hb_next + period)
            sv = self._sv
            io.publish_heartbeat(Heartbeat(sender=cfg.name, fault=bool(sv.latched),
                                           reset_count=sv.reset_count, stamp_s=now, seq=self._hb_seq,
                                           instance=cfg.instance))
            self._hb_seq += 1

        if faults != self._last_faults:
            self._log_transitions(faults, mode, now)
        if fb is not None:
            tau_est, fb_seq = fb.tau.copy(), fb.seq
            lc, temp = fb.load_cell_n, fb.temperature_c
            load_cell = lc.copy() if type(lc) is _ndarray and lc.dtype is _F64 else np.array(lc, dtype=float)
            temperature = (temp.copy() if type(temp) is _ndarray and temp.dtype is _F64
                           else np.array(temp, dtype=float))
        else:
            tau_est, fb_seq, load_cell, temperature = np.zeros(3), -1, _NAN2.copy(), np.zeros(3)
        seq = self.seq
        torso = self.torso
        # positional, in the field order checked at import (_STATE_FIELDS): keywords cost ~1 us more
        s = SpineState(now, seq, mode, requested, _fault(faults), self.rejected, q, dq, tau, tau_est, x, dx,
                       scale, load_cell, temperature, stats.period, stats.jitter_max,
                       _perf_counter() - t_start, fb_seq, command.seq if command is not None else -1,
                       torso.seq if torso is not None else -1)
        self.state = s
        if seq % cfg.state_every == 0:
            io.publish_state(s)
        self.seq = seq + 1
        return s

    def _control(self, mode: int, scale: float, default_gains: bool, q: np.ndarray, dq: np.ndarray):
        c = self.command
        if mode == _PD:
            ctrl = self.ctrl.pd
        else:
            ctrl = self.ctrl.impedance
        torso = self.torso
        ddq1 = torso.ddq1 if torso is not None and torso.ddq1_valid else 0.0
        # the base joint origin's acceleration (hind-body frame) when the estimator gives it, else 0: the
        # paper's fixed-origin law (the decoder has refused a non-finite or out-of-range valid one)
        # (None, not a shared read-only zeros array: the compiled step takes only writable float64 arrays and
        # anything else sends it down the reference path, ~150 us a tick measured)
        base_accel = torso.base_accel if torso is not None and torso.base_accel_valid else None
        try:
            # gains, target and the friction switch change only with the command's numbers, the
            # soft-start scale or the controller: set them then, not every tick (a stream of equal
            # commands costs one compare)
            key = _gains_key(c, scale, default_gains, self._sv.ramp_t0)
            if ctrl is not self._set_ctrl or key != self._set_for:
                self._set_ctrl = None
                if mode != _PD:
                    ctrl.friction_enabled = c.friction_compensation or default_gains
                self._set_gains_and_target(ctrl, c, scale, default_gains, q, dq)
                self._set_ctrl, self._set_for = ctrl, key
            out = ctrl.step(q, dq, ddq1=ddq1, base_accel=base_accel)
        except Exception as exc:  # the loop never dies; the controller promises not to raise anyway
            self._set_ctrl = None
            self._ratelog("controller", self.last_now or 0.0, logging.ERROR, "controller raised: %r", exc)
            return [0.0, 0.0, 0.0], _NAN3.copy(), _NAN3.copy(), False
        x, dx = out.x, out.dx
        x = x.copy() if type(x) is _ndarray and x.dtype is _F64 else np.array(x, dtype=float)
        dx = dx.copy() if type(dx) is _ndarray and dx.dtype is _F64 else np.array(dx, dtype=float)
        if not out.ok:
            self._ratelog("controller", self.last_now or 0.0, logging.ERROR, "controller not ok: %s",
                          out.error)
            return [0.0, 0.0, 0.0], x, dx, False
        tau = _floats(out.tau)
        sat = getattr(out, "saturated", None)  # the law's own clamp cut a torque: TORQUE_CLAMPED as well
        if sat is not None:
            self._law_clamped = bool(sat[0] or sat[1] or sat[2]) if len(sat) == 3 else bool(np.any(sat))
        if not default_gains:
            ff = _floats(c.tau_ff)
            if len(tau) == 3 == len(ff):
                tau = [tau[0] + ff[0], tau[1] + ff[1], tau[2] + ff[2]]
            else:
                tau = [a + b for a, b in zip(tau, ff, strict=True)]
        return tau, x, dx, True

    def _set_gains_and_target(self, ctrl, c: SpineCommand, scale: float, default_gains: bool, q: np.ndarray,
                              dq: np.ndarray) -> None:
        scfg = self.cfg.safety
        k, d = (scfg.default_k, scfg.default_d) if default_gains else (c.k, c.d)
        x_d = np.asarray(c.x_d, dtype=float)
        dx_d, ddx_d = (np.zeros(3), np.zeros(3)) if default_gains else (c.dx_d, c.ddx_d)
        if scale < 1.0 and scfg.soft_start_target:
            x_d, dx_d, ddx_d = self._ramped_target(scale, x_d, dx_d, ddx_d, q, dq)
        ctrl.set_gains(k=[a * scale for a in _floats(k)], d=[a * scale for a in _floats(d)])
        ctrl.set_target(x_d=x_d, dx_d=dx_d, ddx_d=ddx_d)

    def _ramped_target(self, scale: float, x_d, dx_d, ddx_d, q: np.ndarray, dq: np.ndarray):
        """During a soft start the target moves from the pose at the ramp's start to the commanded one,
        so a spine that starts far from its target is not yanked there (as gains come up)."""
        ramp_t0 = self._sv.ramp_t0
        if self._ramp_key != ramp_t0:
            self._ramp_key = ramp_t0
            x0, _ = self.ctrl.task_state(q, dq)
            self._ramp_from = x0 if np.all(np.isfinite(x0)) else None
        if self._ramp_from is None:
            return x_d, dx_d, ddx_d
        x0 = self._ramp_from
        return x0 + scale * (x_d - x0), scale * np.asarray(dx_d), scale * np.asarray(ddx_d)

    def _log_transitions(self, faults: int, mode: Mode, now: float) -> None:
        last = self._last_faults
        quiet = faults & ~_NOISY_BITS
        changed = quiet ^ (last & ~_NOISY_BITS)
        if changed:
            raised, cleared = Fault(changed & quiet), Fault(changed & ~quiet)
            if raised:
                log.warning("t=%.4f s: fault %s raised; running %s", now, raised.name, mode.name)
            if cleared:
                log.info("t=%.4f s: fault %s cleared; running %s", now, cleared.name, mode.name)
        noisy_new = faults & _NOISY_BITS & ~last
        if noisy_new:
            self._ratelog(f"noisy:{noisy_new}", now, logging.INFO, "t=%.4f s: %s", now, Fault(noisy_new).name)
        self._last_faults = faults

    def safe_tick(self, now: float, feedback: MotorFeedback | None, wall_s: float | None = None) -> None:
        """`tick`, but an unexpected exception (a bug, a full disk under a logger, ...) stops the motors
        for this tick and is logged instead of ending the loop."""
        try:
            self.tick(now, feedback, wall_s)
        except Exception as exc:
            self.tick_errors += 1
            self._ratelog("tick", now, logging.ERROR, "control tick failed (%d so far), motors stopped: %r",
                          self.tick_errors, exc)
            try:
                stop = MotorCommand.zero(3, enable=False)
                stop.seq, stop.stamp_s = self.seq, now  # in the sequence, like every command of the node
                self.bus.send(stop)
            except Exception as exc2:  # the bus is broken too: nothing more to do this tick
                self._ratelog("tick-bus", now, logging.ERROR, "could not stop motors: %r", exc2)
            self.seq += 1

    def resend(self) -> None:
        """Send the last motor command again (lockstep: the robot repeated a tick whose answer was lost)."""
        if self.last_command is None:
            return
        try:
            self.bus.send(self.last_command)
        except MotorBusError as exc:
            self._bus_error(exc, self.last_now if self.last_now is not None else 0.0)

    def idle_heartbeat(self) -> None:
        """Heartbeat while waiting for the first (or a late) feedback tick in lockstep, so the robot side
        knows the node is up; stamped with the node's last time."""
        now = self.last_now if self.last_now is not None else 0.0
        sv = self._sv
        self.io.publish_heartbeat(Heartbeat(sender=self.cfg.name, fault=bool(sv.latched),
                                            reset_count=sv.reset_count, stamp_s=now, seq=self._hb_seq,
                                            instance=self.cfg.instance))
        self._hb_seq += 1

    def stop(self) -> None:
        """Zero torque, motors stopped; safe to call more than once."""
        try:
            self.bus.stop()
        except MotorBusError as exc:
            log.error("could not stop motors: %s", exc)


def _floats(a: object) -> list[float]:
    if type(a) is _ndarray and a.dtype is _F64:
        return a.tolist()
    return np.asarray(a, dtype=float).tolist()


def _finite3(a: object) -> list[float] | None:
    """a as 3 finite floats, or None (feedback check on plain floats)."""
    try:
        vals = a.tolist() if isinstance(a, np.ndarray) else list(a)
        if len(vals) == 3 and math.isfinite(vals[0]) and math.isfinite(vals[1]) and math.isfinite(vals[2]):
            return [float(v) for v in vals]
    except (TypeError, ValueError):
        pass
    return None


def _gains_key(c: SpineCommand, scale: float, default_gains: bool, ramp_t0: float | None) -> tuple:
    """Everything the controller's gains, target and friction switch are computed from."""
    x_d = c.x_d
    if type(x_d) is _ndarray and x_d.dtype is _F64:  # decoded commands: five float64 arrays, their bytes
        if default_gains:
            return scale, True, ramp_t0, x_d.tobytes()
        try:
            return (scale, False, ramp_t0, c.friction_compensation, x_d.tobytes(), c.k.tobytes(),
                    c.d.tobytes(), c.dx_d.tobytes(), c.ddx_d.tobytes())
        except AttributeError:  # a hand-built command mixing arrays and sequences
            pass
    if default_gains:
        return scale, True, ramp_t0, *_floats(x_d)
    return (scale, False, ramp_t0, c.friction_compensation, *_floats(x_d), *_floats(c.k), *_floats(c.d),
            *_floats(c.dx_d), *_floats(c.ddx_d))


_FAULTS: dict[int, Fault] = {}


def _fault(bits: int) -> Fault:
    """Fault(bits), memoised: the enum call costs ~0.5 us, the node needs it once per tick."""
    f = _FAULTS.get(bits)
    if f is None:
        f = _FAULTS[bits] = Fault(bits)
    return f


# --- loops ------------------------------------------------------------------------------------------
@dataclass
class RunResult:
    ticks: int
    elapsed_wall_s: float
    achieved_rate_hz: float
    jitter_max_s: float
    overruns: int = 0


def run_realtime(node: SpineNode, duration_s: float | None = None,
                 stop: threading.Event | Callable[[], bool] | None = None) -> RunResult:
    """Fixed-rate loop at `node.cfg.rate_hz` on the monotonic clock: each tick drains the bus (newest
    feedback wins), then steps. Stops after `duration_s` or when `stop` is set."""
    stopped = _stopper(stop)
    node.drain_inputs(0.0)  # what queued before the loop starts is old: dropped, counted; node time 0 = now
    clock = RealTimeClock(node.cfg.rate_hz)
    t_wall0 = time.monotonic()
    ticks = 0
    jitter = 0.0
    try:
        while not stopped():
            now = clock.wait()
            if duration_s is not None and now > duration_s:
                break
            newest = None
            while True:
                fb = node.receive(0.0)
                if fb is None:
                    break
                newest = fb
            node.safe_tick(now, newest, wall_s=clock.t0 + now)
            jitter = max(jitter, node.stats.jitter_max)
            ticks += 1
    finally:
        node.stop()
    elapsed = time.monotonic() - t_wall0
    return RunResult(ticks, elapsed, ticks / elapsed if elapsed > 0 else 0.0, jitter, clock.overruns)


# Lockstep: how long a tick's feedback waits for the torso state of the same tick (same seq) when the
# newest torso state the node has is the previous tick's (a robot that publishes one per tick). A robot
# that numbers its torso states otherwise, or that stopped sending them, is not waited for; a lost one
# costs this once, and the tick runs on the last torso state (the stale-torso watchdog judges it as ever).
LOCKSTEP_TORSO_WAIT_S = 0.1  # wall s: paid in full only for a torso state that never comes


def run_lockstep(node: SpineNode, duration_s: float | None = None,
                 stop: threading.Event | Callable[[], bool] | None = None,
                 idle_timeout_s: float = 5.0, max_ticks: int | None = None,
                 startup_timeout_s: float = 120.0) -> RunResult:
    """One control step per motor feedback tick; node time = the feedback's stamp. Returns when the
    robot has been silent for `idle_timeout_s` of wall time (before its first feedback: for
    `startup_timeout_s`, since a simulated robot may take long to start on a loaded machine), after
    `duration_s` of node time, after `max_ticks`, or when `stop` is set.

    A robot that publishes each tick's torso state with the tick's seq (as `robot_side` does) gets the
    q1 of that very tick on every tick, whatever order the transport delivers the two in
    (LOCKSTEP_TORSO_WAIT_S); `node.lockstep_torso_missing` counts the ticks that ran without it. The first
    tick also waits for the robot's opening heartbeat and command (else it would run disabled where an
    in-process node runs the commanded mode); `node.lockstep_opening_incomplete` says it ran without."""
    stopped = _stopper(stop)
    t_wall0 = time.monotonic()
    ticks = 0
    first: float | None = None
    last_heard = time.monotonic()
    inbox = node.io.inbox
    try:
        while not stopped() and (max_ticks is None or ticks < max_ticks):
            fb = node.receive(0.05)
            if fb is None:
                node.idle_heartbeat()
                limit = idle_timeout_s if first is not None else max(idle_timeout_s, startup_timeout_s)
                if time.monotonic() - last_heard > limit:
                    log.info("lockstep: no motor feedback for %.1f s, stopping", limit)
                    break
                continue
            last_heard = time.monotonic()
            if ticks and fb.seq <= node.state.feedback_seq:  # a repeated tick: answer again, do not step
                node.repeated_ticks += 1
                node.resend()
                continue
            now = fb.stamp_s
            first = now if first is None else first
            if duration_s is not None and now - first > duration_s:
                break
            newest = inbox.torso or node.torso
            if not ticks:  # the opening tick: its torso state, heartbeat and command may still be on the way
                if not node.io.await_inbox(partial(opening_inputs_in, seq=fb.seq), LOCKSTEP_TORSO_WAIT_S):
                    node.lockstep_opening_incomplete = True
            elif (newest is not None and newest.seq == fb.seq - 1
                    and not node.io.await_torso(fb.seq, LOCKSTEP_TORSO_WAIT_S)):
                node.lockstep_torso_missing += 1
            node.safe_tick(now, fb)
            ticks += 1
    finally:
        node.stop()
    elapsed = time.monotonic() - t_wall0
    return RunResult(ticks, elapsed, ticks / elapsed if elapsed > 0 else 0.0, node.stats.jitter_max)


def _stopper(stop) -> Callable[[], bool]:
    if stop is None:
        return lambda: False
    if isinstance(stop, threading.Event):
        return stop.is_set
    return stop
