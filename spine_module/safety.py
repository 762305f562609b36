"""The spine node's safety logic: watchdogs, latches and clamps as pure functions of state and time.

Nothing here reads a clock or keeps hidden state: the node passes `now` (its own clock, s), the receipt
times of its inputs and the previous `SafetyState`, and gets back a new state and a `Verdict` saying
which mode to run and how. Every behaviour below is documented in docs/robot-side.md ("Safety") and has a
fault-injection test in `tests/spine_module/node/` and `tests/integration/`.

Behaviours (deadlines from `params.SAFETY`):
- torso state older than `torso_deadline_s` (or never received): q1 is not trusted, the node runs the
  damping mode; it recovers by itself when fresh state returns (with a new soft start).
- motor feedback older than `feedback_deadline_s` (or never received): zero torque.
- no command for `command_deadline_s`: hold the last target in impedance mode with the default gains.
- robot heartbeat older than `heartbeat_deadline_s` once seen: latched HEARTBEAT_LOST, zero torque with
  the motors stopped, until a reset while the heartbeat is fresh. Until the first heartbeat (when
  required) the node waits with the motors stopped.
- E-stop command: latched ESTOP, zero torque, motors stopped, until a reset with a non-E-stop command.
- torques clamp at +-torque limit; inside `JOINT_LIMIT_MARGIN_RAD` of a joint limit, moving towards it,
  damping is added (reported as JOINT_LIMIT).
- entering impedance or PD mode ramps K and D from 0 to 1 over `soft_start_s` (the node also moves the
  target in from the pose at the ramp's start, `soft_start_target`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from spine_module import params
from spine_module.messages.types import LATCHING, MODES, Fault, Mode

TORQUE_MODES = (Mode.IMPEDANCE, Mode.PD, Mode.JOINT_TORQUE)
RAMPED_MODES = (Mode.IMPEDANCE, Mode.PD)


def _lims(which: dict[str, float]) -> np.ndarray:
    return np.array([which[j] for j in params.ACTUATED_JOINTS])


@dataclass(frozen=True)
class SafetyConfig:
    torso_deadline_s: float = params.SAFETY.torso_deadline_s
    feedback_deadline_s: float = params.SAFETY.feedback_deadline_s
    command_deadline_s: float = params.SAFETY.command_deadline_s
    heartbeat_deadline_s: float = params.SAFETY.heartbeat_deadline_s
    soft_start_s: float = params.SAFETY.soft_start_s
    stale_resume_s: float = params.SAFETY.stale_resume_s
    soft_start_target: bool = True  # during the soft start the target also moves in from the current pose
    joint_limit_damping: float = params.SAFETY.joint_limit_damping_nm_s_rad
    damping_mode: float = params.SAFETY.damping_mode_nm_s_rad
    torque_limit: float = params.TORQUE_LIMIT_NM
    lower: np.ndarray = field(default_factory=lambda: _lims(params.JOINT_LOWER_RAD))
    upper: np.ndarray = field(default_factory=lambda: _lims(params.JOINT_UPPER_RAD))
    limit_margin: float = params.JOINT_LIMIT_MARGIN_RAD
    heartbeat_required: bool = True
    default_k: np.ndarray = field(default_factory=lambda: params.K_DEFAULT.copy())
    default_d: np.ndarray = field(default_factory=lambda: params.D_DEFAULT.copy())


class Receipts(NamedTuple):
    """When each input last arrived (valid), on the node's clock, s; None if never."""

    torso: float | None = None
    feedback: float | None = None
    command: float | None = None
    heartbeat: float | None = None


@dataclass(frozen=True)
class SafetyState:
    latched: Fault = Fault.NONE
    heartbeat_seen: bool = False
    mode: Mode = Mode.DISABLED  # mode that ran last tick
    ramp_t0: float | None = None  # when the running ramped mode started
    stale_since: float | None = None  # start of the current feedback-stale spell that paused a ramped mode
    reset_count: int = 0  # resets accepted so far (sent to the robot side in the heartbeat)


@dataclass(frozen=True)
class Verdict:
    mode: Mode  # mode to run this tick
    faults: Fault  # active and latched faults (watchdogs; clamp bits are added by the node)
    gain_scale: float  # soft-start factor on K and D, 0..1
    default_gains: bool  # command stale: hold the last target with the default gains
    enable: bool  # False: motors stopped (zero torque)


class Supervised(NamedTuple):
    """One tick of `supervise_values` as plain values (fault bits and modes as ints: IntFlag arithmetic costs
    ~1 us per operation at 1 kHz): the safety state, fed back as the next tick's `prev`, then the verdict."""

    latched: int = 0  # latched fault bits
    heartbeat_seen: bool = False
    mode: int = int(Mode.DISABLED)  # the mode to run (this tick's; last tick's when fed back)
    ramp_t0: float | None = None
    stale_since: float | None = None
    reset_count: int = 0
    faults: int = 0  # active and latched fault bits
    gain_scale: float = 0.0
    default_gains: bool = False
    enable: bool = False


_tuple_new = tuple.__new__

# Deadlines compare with this slack so that float sums of tick times (0.001 * k) do not trip a deadline
# one tick early: an input exactly `deadline` old is still fresh.
EPS_S = 1e-9


def age(now: float, t: float | None) -> float:
    return math.inf if t is None else now - t - EPS_S


_TORSO_STALE, _FEEDBACK_STALE, _COMMAND_STALE = (int(Fault.TORSO_STALE), int(Fault.FEEDBACK_STALE),
                                                 int(Fault.COMMAND_STALE))
_HEARTBEAT_LOST, _ESTOP, _WAITING = int(Fault.HEARTBEAT_LOST), int(Fault.ESTOP), int(Fault.WAITING)
_LATCHING = int(LATCHING)
_DISABLED, _DAMPING, _IMPEDANCE, _ESTOP_MODE = (int(Mode.DISABLED), int(Mode.DAMPING), int(Mode.IMPEDANCE),
                                               int(Mode.ESTOP))
_INF = math.inf
_TORQUE = frozenset(int(m) for m in TORQUE_MODES)
_TORQUE_OR_DAMPING = _TORQUE | {_DAMPING}
_RAMPED = frozenset(int(m) for m in RAMPED_MODES)


def supervise(state: SafetyState, now: float, rx: Receipts, requested: Mode, reset: bool,
              cfg: SafetyConfig) -> tuple[SafetyState, Verdict]:
    """One tick of the watchdogs and latches. `reset` is True on the tick a command asking for a reset
    arrives; `requested` is the mode of the command in force (DISABLED before any)."""
    prev = Supervised(int(state.latched), state.heartbeat_seen, int(state.mode), state.ramp_t0,
                      state.stale_since, state.reset_count)
    v = supervise_values(prev, now, rx, int(requested), reset, cfg)
    new = SafetyState(latched=Fault(v.latched), heartbeat_seen=v.heartbeat_seen, mode=MODES[v.mode],
                      ramp_t0=v.ramp_t0, stale_since=v.stale_since, reset_count=v.reset_count)
    return new, Verdict(mode=MODES[v.mode], faults=Fault(v.faults), gain_scale=v.gain_scale,
                        default_gains=v.default_gains, enable=v.enable)


def supervise_values(prev: Supervised, now: float, rx: Receipts, requested: int, reset: bool,
                     cfg: SafetyConfig) -> Supervised:
    """`supervise` on plain values, for the node's 1 kHz tick: no enum objects, no IntFlag arithmetic;
    `prev` is the last tick's result (`Supervised()` before the first). `supervise` is this function with
    `SafetyState`/`Verdict` around it."""
    latched, heartbeat_seen, last_mode, ramp_t0, stale_since, reset_count, _, _, _, _ = prev
    rx_torso, rx_feedback, rx_command, rx_heartbeat = rx
    heartbeat_seen = heartbeat_seen or rx_heartbeat is not None
    # an input never received is infinitely old (as `age`), also against an infinite deadline
    hb_age = _INF if rx_heartbeat is None else now - rx_heartbeat - EPS_S
    heartbeat_fresh = hb_age <= cfg.heartbeat_deadline_s
    heartbeat_required = cfg.heartbeat_required

    if reset:
        reset_count += 1
        if heartbeat_fresh or not heartbeat_required:
            latched &= ~_HEARTBEAT_LOST
        if requested != _ESTOP_MODE:
            latched &= ~_ESTOP
    if requested == _ESTOP_MODE:
        latched |= _ESTOP
    if heartbeat_required and heartbeat_seen and not heartbeat_fresh:
        latched |= _HEARTBEAT_LOST

    active = 0
    if heartbeat_required and not heartbeat_seen:
        active |= _WAITING
    if rx_feedback is None:
        active |= _WAITING
    elif now - rx_feedback - EPS_S > cfg.feedback_deadline_s:
        active |= _FEEDBACK_STALE
    if (_INF if rx_torso is None else now - rx_torso - EPS_S) > cfg.torso_deadline_s:
        active |= _TORSO_STALE
    command_stale = rx_command is not None and now - rx_command - EPS_S > cfg.command_deadline_s
    if command_stale:
        active |= _COMMAND_STALE

    default_gains = False
    enable = True
    if latched & _ESTOP:
        mode, enable = _ESTOP_MODE, False
    elif latched & _LATCHING or active & _WAITING:
        mode, enable = _DISABLED, False
    elif active & _FEEDBACK_STALE:
        mode = _DISABLED  # zero torque, motors left enabled so fresh feedback resumes control at once
    elif active & _TORSO_STALE and requested in _TORQUE_OR_DAMPING:
        mode = _DAMPING  # a DISABLED request stays disabled: the fallback never energises motors
    elif command_stale and requested in _TORQUE:
        mode, default_gains = _IMPEDANCE, True
    else:
        mode = _DISABLED if requested == _ESTOP_MODE else requested
        enable = mode != _DISABLED

    # a feedback-stale spell inside a ramped mode pauses it: zero torque, motors still enabled, the ramp
    # kept, so a short gap resumes where it was (full gain once the ramp is done). Only a real restart (a
    # stop, another mode, or a gap longer than stale_resume_s) soft-starts again.
    was_stale = stale_since is not None
    paused = (mode == _DISABLED and enable and active & _FEEDBACK_STALE
              and (last_mode in _RAMPED or was_stale) and ramp_t0 is not None)
    if paused:
        if stale_since is None:  # the spell began when the feedback went stale, not at this (maybe late) tick
            stale_since = now if rx_feedback is None else min(now, rx_feedback + cfg.feedback_deadline_s)
        # a long gap, or a torso state gone stale meanwhile (its recovery soft-starts: q1 was not trusted),
        # restarts the ramp
        if now - stale_since > cfg.stale_resume_s or active & _TORSO_STALE:
            ramp_t0, stale_since = None, None
        scale = 0.0
    else:
        stale_since = None
        if mode in _RAMPED:
            resumed = was_stale and ramp_t0 is not None
            if not resumed and (last_mode not in _RAMPED or ramp_t0 is None):
                ramp_t0 = now
            ramp_s = cfg.soft_start_s
            if ramp_s <= 0:
                scale = 1.0
            else:  # min(1, max(0, r)) as comparisons (NaN gives 0 as there)
                r = (now - ramp_t0) / ramp_s
                scale = 1.0 if r >= 1.0 else r if r > 0.0 else 0.0
        else:
            ramp_t0 = None
            scale = 1.0 if mode in _TORQUE else 0.0
    # tuple.__new__ directly: a NamedTuple's own __new__ is a Python function (~1 us a call at 1 kHz)
    return _tuple_new(Supervised, (latched, heartbeat_seen, mode, ramp_t0, stale_since, reset_count,
                                   latched | active, scale, default_gains, enable))


class TorqueLimits(NamedTuple):
    """The numbers of the output stage (`limit_torque`) as plain floats, built once (`of`, `from_config`)."""

    lower: tuple[float, float, float]  # joint limits q2..q4, rad
    upper: tuple[float, float, float]
    margin: float  # rad inside a limit where the limit damping starts
    damping: float  # limit damping at the limit, N*m*s/rad
    torque: float  # torque clamp, +-N*m
    clear: tuple[float, float, float, float, float, float] | None  # (lo0, hi0, lo1, ...): clear of the margin

    @classmethod
    def of(cls, lower: Sequence[float], upper: Sequence[float], margin: float, damping: float,
           torque: float) -> TorqueLimits:
        lo, hi = tuple(float(v) for v in lower), tuple(float(v) for v in upper)
        if len(lo) != 3 or len(hi) != 3:
            raise ValueError(f"torque limits are for 3 joints, got {len(lo)} lower and {len(hi)} upper")
        # the same float expressions joint_limit_damping_list's shortcut compares with
        clear = (lo[0] + margin, hi[0] - margin, lo[1] + margin, hi[1] - margin, lo[2] + margin,
                 hi[2] - margin) if margin > 0 else None
        return cls(lo, hi, float(margin), float(damping), float(torque), clear)

    @classmethod
    def from_config(cls, cfg: SafetyConfig) -> TorqueLimits:
        return cls.of(cfg.lower, cfg.upper, cfg.limit_margin, cfg.joint_limit_damping, cfg.torque_limit)


def limit_torque(tau: Sequence[float], q: Sequence[float], dq: Sequence[float],
                 lim: TorqueLimits) -> tuple[float, float, float, bool, bool]:
    """The node's output stage on three joints, the one implementation the node and the simulated direct
    spine share: the joint-limit damping (`joint_limit_damping_list`) added where a joint is inside its
    margin, then the clamp (`clamp_torque_list`). Returns (tau2, tau3, tau4 N*m, near_limit: the damping
    was added (JOINT_LIMIT), clamped: a torque was cut or not finite (TORQUE_CLAMPED)), a plain tuple (a
    NamedTuple costs 0.2 us more, per step of a bound too). The usual tick (every joint clear of its
    margin, every torque inside the limit) makes only the comparisons and builds no list; NaN fails them
    and takes the full path."""
    a, b, c = tau
    qa, qb, qc = q
    near = False
    k = lim.clear
    if not (k is not None and k[0] <= qa <= k[1] and k[2] <= qb <= k[3] and k[4] <= qc <= k[5]):
        extra, active = joint_limit_damping_list([float(qa), float(qb), float(qc)], [float(v) for v in dq],
                                                 list(lim.lower), list(lim.upper), lim.margin, lim.damping)
        if active[0] or active[1] or active[2]:
            near = True
            a, b, c = a + extra[0], b + extra[1], c + extra[2]
    t = lim.torque
    if -t <= a <= t and -t <= b <= t and -t <= c <= t:
        return a, b, c, near, False
    (a, b, c), sat = clamp_torque_list([a, b, c], t)
    return a, b, c, near, sat[0] or sat[1] or sat[2]


def clamp_torque(tau: np.ndarray, limit: float) -> tuple[np.ndarray, np.ndarray]:
    """Clamp to +-limit; non-finite entries become 0 and count as saturated. Returns (tau, saturated)."""
    tau = np.asarray(tau, dtype=float)
    out, sat = clamp_torque_list(tau.reshape(-1).tolist(), limit)
    return np.array(out).reshape(tau.shape), np.array(sat, dtype=bool).reshape(tau.shape)


_NO_SAT3 = (False, False, False)


def clamp_torque_list(tau: list[float], limit: float) -> tuple[list[float], list[bool]]:
    """`clamp_torque` on plain floats (the node's 1 kHz path: three numbers, no numpy temporaries)."""
    if len(tau) == 3:  # the usual tick: three finite torques inside the limit (NaN fails the comparisons)
        a, b, c = tau
        if -limit <= a <= limit and -limit <= b <= limit and -limit <= c <= limit:
            return [a, b, c], list(_NO_SAT3)
    out, sat = [], []
    for t in tau:
        if not math.isfinite(t):
            out.append(0.0)
            sat.append(True)
        else:
            out.append(limit if t > limit else -limit if t < -limit else t)
            sat.append(abs(t) > limit)
    return out, sat


def damping_torque(dq: Sequence[float], c: float) -> list[float]:
    """The damping (safe) mode: tau = -c dq, on plain floats (the node's 1 kHz path)."""
    return [-c * a for a in dq]


def joint_limit_damping(q: np.ndarray, dq: np.ndarray, lower: np.ndarray, upper: np.ndarray, margin: float,
                        c: float) -> tuple[np.ndarray, np.ndarray]:
    """Extra damping for joints inside `margin` of a limit and moving towards it.

    The coefficient grows linearly from 0 at the margin's edge to `c` at the limit (and stays `c`
    beyond it). Returns (tau to add, active mask)."""
    q, dq, lower, upper = np.broadcast_arrays(*(np.asarray(a, dtype=float) for a in (q, dq, lower, upper)))
    extra, active = joint_limit_damping_list(q.reshape(-1).tolist(), dq.reshape(-1).tolist(),
                                             lower.reshape(-1).tolist(), upper.reshape(-1).tolist(),
                                             margin, c)
    return np.array(extra).reshape(q.shape), np.array(active, dtype=bool).reshape(q.shape)


def joint_limit_damping_list(q: list[float], dq: list[float], lower: list[float], upper: list[float],
                             margin: float, c: float) -> tuple[list[float], list[bool]]:
    """`joint_limit_damping` on plain floats (the node's 1 kHz path)."""
    if margin > 0 and len(q) == 3 == len(lower) == len(upper) == len(dq):
        # the usual tick: every joint clear of its margin (the same float expressions as below give depth 0;
        # NaN fails the comparisons and takes the full path)
        if ((lower[0] + margin) <= q[0] <= (upper[0] - margin)
                and (lower[1] + margin) <= q[1] <= (upper[1] - margin)
                and (lower[2] + margin) <= q[2] <= (upper[2] - margin)):
            return [-c * 0.0 * dq[0], -c * 0.0 * dq[1], -c * 0.0 * dq[2]], list(_NO_SAT3)
    extra, active = [], []
    for qi, dqi, lo, hi in zip(q, dq, lower, upper, strict=True):
        depth_hi = min(1.0, max(0.0, (qi - (hi - margin)) / margin))
        depth_lo = min(1.0, max(0.0, ((lo + margin) - qi) / margin))
        towards = depth_hi if dqi > 0 else depth_lo
        extra.append(-c * towards * dqi)
        active.append(depth_hi > 0 or depth_lo > 0)
    return extra, active
