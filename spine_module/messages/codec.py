"""LCM encode/decode with validation: every decoded message is finite and in range, or rejected with
a `MessageError` that names the channel and the bad field (`SPARC_SPINE_COMMAND.k[0]: ...`).

A message whose 8-byte fingerprint is not the channel's type raises `FingerprintError` naming both the
expected type and, when it is one of ours, the type that was actually sent.
"""

from __future__ import annotations

import functools
import math
import struct
from collections.abc import Callable
from dataclasses import dataclass, fields
from io import BytesIO
from typing import ParamSpec

import numpy as np

from spine_module import params
from spine_module.messages import channels
from spine_module.messages.layout import layouts
from spine_module.messages.lcmt.sparc import (
    heartbeat_t,
    motor_command_t,
    motor_feedback_t,
    spine_command_t,
    spine_state_t,
    torso_state_t,
)
from spine_module.messages.motor import MotorCommand, MotorFeedback
from spine_module.messages.types import MODES, Fault, Heartbeat, Mode, SpineCommand, SpineState, TorsoState
from spine_module.workspace import SPARC, Workspace

LCM_TYPES = (torso_state_t, spine_command_t, spine_state_t, motor_command_t, motor_feedback_t, heartbeat_t)

TYPE_BY_CHANNEL: dict[str, type] = {
    channels.TORSO_STATE: torso_state_t,
    channels.SPINE_COMMAND: spine_command_t,
    channels.SPINE_STATE: spine_state_t,
    channels.MOTOR_COMMAND: motor_command_t,
    channels.MOTOR_FEEDBACK: motor_feedback_t,
    channels.HEARTBEAT_NODE: heartbeat_t,
    channels.HEARTBEAT_ROBOT: heartbeat_t,
}


class MessageError(ValueError):
    """A message was rejected. `field` is e.g. "k[0]" ("" for whole-message errors)."""

    def __init__(self, channel: str, field: str, reason: str):
        self.channel, self.field, self.reason = channel, field, reason
        where = f"{channel}.{field}" if field else channel
        super().__init__(f"{where}: {reason}")


class FingerprintError(MessageError):
    """The payload's LCM fingerprint is not the channel's type (different or stale lcm_types)."""


def type_name(cls: type) -> str:
    return f"sparc.{cls.__name__}"


_BY_FINGERPRINT = {cls._get_packed_fingerprint(): cls for cls in LCM_TYPES}


# --- validation ranges ---------------------------------------------------------------------------
@dataclass(frozen=True)
class Range:
    """Accepted values of one field: lo <= v <= hi (NaN only if nan_ok). `reason` replaces the default
    rejection text (NaN / infinite / outside the range); "{v}" in it is the value as sent."""

    lo: float
    hi: float
    unit: str = ""
    nan_ok: bool = False
    reason: str = ""


_PI = math.pi
_TAU_MAX = params.TORQUE_LIMIT_NM
_VEL_MAX = params.VELOCITY_LIMIT_RAD_S
# Interface sanity limits. They reject garbage, not merely unusual commands: gains up to 10x the paper's.
K_MAX = (5000.0, 10000.0, 150.0)  # N/m, N/m, N*m/rad
D_MAX = (200.0, 200.0, 10.0)  # N*s/m, N*s/m, N*m*s/rad

_NOT_NEGATIVE = Range(0.0, math.inf, reason="{v} is negative")
HEADER_RANGES = {"seq": _NOT_NEGATIVE, "utime": _NOT_NEGATIVE}  # seq is checked (and named) first
MODE_RANGE = Range(0.0, float(len(MODES) - 1), reason=f"{{v}} is not a mode (0..{max(Mode)})")  # MODES[v]
MOTOR_MODE_RANGE = Range(0.0, 2.0, reason="{v} is not a motor mode (0 reset, 1 cal, 2 run)")
QUAT_NORM_MIN, QUAT_NORM_MAX = 0.9, 1.1  # torso quaternion: renormalised within these norms, else refused
TORSO_RANGES = {
    "q1": Range(-_PI, _PI, "rad"),
    "dq1": Range(-50.0, 50.0, "rad/s"),
    "ddq1": Range(-5000.0, 5000.0, "rad/s^2"),
    # no element of a quaternion whose norm is within 10 % of 1 exceeds 1.1; the norm itself is checked by
    # the decoders (`_not_unit`), the same at every orientation
    "quat": Range(-QUAT_NORM_MAX, QUAT_NORM_MAX, ""),
    "omega": Range(-50.0, 50.0, "rad/s"),
    "base_accel": Range(-500.0, 500.0, "m/s^2"),  # 50 g: beyond any landing of a legged robot
}
# checked only when their validity flag is set (else replaced by 0): ddq1 by ddq1_valid, base_accel by
# base_accel_valid
_TORSO_GATED = {"ddq1": "ddq1_valid", "base_accel": "base_accel_valid"}


def command_ranges(reach_m: float) -> dict[str, Range | list[Range]]:
    """A spine command's per-field ranges for a spine whose straight pose reaches `reach_m` along x."""
    return {
        "x_d": [Range(0.0, reach_m, "m"), Range(-reach_m, reach_m, "m"), Range(-_PI, _PI, "rad")],
        "dx_d": [Range(-5.0, 5.0, "m/s"), Range(-5.0, 5.0, "m/s"), Range(-50.0, 50.0, "rad/s")],
        "ddx_d": [Range(-500.0, 500.0, "m/s^2"), Range(-500.0, 500.0, "m/s^2"),
                  Range(-5000.0, 5000.0, "rad/s^2")],
        "k": [Range(0.0, K_MAX[0], "N/m"), Range(0.0, K_MAX[1], "N/m"), Range(0.0, K_MAX[2], "N*m/rad")],
        "d": [Range(0.0, D_MAX[0], "N*s/m"), Range(0.0, D_MAX[1], "N*s/m"),
              Range(0.0, D_MAX[2], "N*m*s/rad")],
        "tau_ff": Range(-_TAU_MAX, _TAU_MAX, "N*m"),
    }


COMMAND_RANGES = command_ranges(SPARC.reach_m)  # the SPARC module's
_CG = params.CYBERGEAR
_POS_MAX = max(_CG.position_rad, _CG.position_table_rad)  # either scaling of the frames' position
FEEDBACK_RANGES = {
    "angle": Range(-_POS_MAX, _POS_MAX, "rad"),
    "velocity": Range(-1.5 * _VEL_MAX, 1.5 * _VEL_MAX, "rad/s"),
    "torque": Range(-1.5 * _TAU_MAX, 1.5 * _TAU_MAX, "N*m"),
    "temperature": Range(-40.0, 200.0, "degC"),
    "load_cell": Range(-2000.0, 2000.0, "N", nan_ok=True),
}
MOTOR_COMMAND_RANGES = {
    "position": Range(-_POS_MAX, _POS_MAX, "rad"),
    "velocity": Range(-_VEL_MAX, _VEL_MAX, "rad/s"),
    "kp": Range(0.0, _CG.kp_nm_rad, "N*m/rad"),
    "kd": Range(0.0, _CG.kd_nm_s_rad, "N*m*s/rad"),
    "torque": Range(-_TAU_MAX, _TAU_MAX, "N*m"),
}


def _in_bounds(v: np.ndarray, lo: np.ndarray, hi: np.ndarray, nan_ok: np.ndarray | None) -> np.ndarray:
    """lo <= v <= hi elementwise (NaN fails unless nan_ok). Fresh arrays, no shared scratch buffers: a
    decode may run in an LCM handler thread and the node's thread at once."""
    ok = v >= lo
    ok &= v <= hi
    if nan_ok is not None:
        ok |= np.isnan(v) & nan_ok
    return ok


def _reason(v: float, r: Range) -> str:
    """Why `v` (as sent) is outside `r`; called only for a value `_in_bounds` refused."""
    if r.reason:
        return r.reason.format(v=v)
    if v != v:
        return "NaN"
    if v in (math.inf, -math.inf):
        return f"{v} (infinite)"
    return f"{v:.6g} outside [{r.lo:.6g}, {r.hi:.6g}] {r.unit}".rstrip()


_LAYOUTS = layouts(LCM_TYPES)


class Bounds:
    """What one message type accepts, as bounds on the values of its layout's flat vector (the order of
    `Layout.unpack`: header, enums and booleans included), built from a table of `Range`s by field name.

    The fast decoders unpack a message and accept it with one vectorised comparison; when that fails,
    and in the field-by-field `decode_*_checked` paths, the same object names the first bad field in the
    table's order (the order the checks have always run in, so the errors are unchanged). A fixed-size
    layout is compared whole (a value without an entry is unbounded: a NaN there fails the comparison,
    finds no bad field and is accepted); a layout with strings compares only the values in the table."""

    def __init__(self, cls: type, table: dict[str, Range | list[Range]]) -> None:
        self.layout = layout = _LAYOUTS[cls]
        strings = {lo for st, lo, _hi in layout.parts if st is None}
        is_array = {name: arr for name, _a, _n, arr, _b in layout.fields}
        checks: list[tuple[int, str, Range]] = []  # (flat index, field label, range) in table order
        for name, r in table.items():
            a, k = layout.index(name)
            per = r if isinstance(r, list) else [r] * k
            if a in strings or len(per) != k:
                raise ValueError(f"{cls.__name__}.{name}: {len(per)} numeric ranges for {k} values")
            checks += [(a + i, f"{name}[{i}]" if is_array[name] else name, ri) for i, ri in enumerate(per)]
        # the compared vector: every value, or (strings in the layout) the checked ones in flat order
        at = list(range(layout.n_values)) if not strings else sorted(i for i, _label, _r in checks)
        self._pick = None if not strings else (lambda vals, at=tuple(at): [vals[i] for i in at])
        pos = {flat: j for j, flat in enumerate(at)}
        self.checks = tuple(checks)
        self._walk = tuple((pos[i], label, r) for i, label, r in checks)  # positions in the compared vector
        self.lo, self.hi = np.full(len(at), -math.inf), np.full(len(at), math.inf)
        nan_ok = np.zeros(len(at), dtype=bool)
        for j, _label, r in self._walk:
            self.lo[j], self.hi[j], nan_ok[j] = r.lo, r.hi, r.nan_ok
        self.nan_ok = nan_ok if nan_ok.any() else None

    def values(self, m: object) -> list:
        """The flat values of a generated message object, in layout order (`Layout.unpack`'s)."""
        out: list = []
        for name, _a, _n, is_array, _b in self.layout.fields:
            if is_array:
                out += getattr(m, name)
            else:
                out.append(getattr(m, name))
        return out

    def check(self, channel: str, vals: list | tuple) -> np.ndarray:
        """The compared values of `vals` (flat, as `Layout.unpack` or `values` give them) as one float
        vector (for a fixed-size layout: all of them, in order), or a MessageError naming the first bad
        field."""
        if self._pick is not None:
            vals = self._pick(vals)
        v = np.array(vals, dtype=float)
        ok = _in_bounds(v, self.lo, self.hi, self.nan_ok).tolist()
        if not all(ok):  # a C-level pass over Python bools: ~0.6 us under ndarray.all()
            for j, label, r in self._walk:
                if not ok[j]:
                    raise MessageError(channel, label, _reason(vals[j], r))
        return v

    def check_message(self, channel: str, m: object) -> np.ndarray:
        """`check` of a generated message object (the field-by-field paths)."""
        return self.check(channel, self.values(m))


def _blank(cls: type):
    """A generated message object without running its constructor (every field is assigned next)."""
    return object.__new__(cls) if cls in _LAYOUTS else cls()


def _encode(m) -> bytes:
    layout = _LAYOUTS.get(type(m))
    return layout.encode(m) if layout is not None else m.encode()


# --- raw decode -------------------------------------------------------------------------------------
def decode_raw(channel: str, data: bytes, cls: type | None = None):
    """Bytes -> generated LCM object, checking fingerprint and length. No range checks."""
    if cls is None:
        cls = TYPE_BY_CHANNEL.get(channel)
        if cls is None:
            raise MessageError(channel, "", "unknown channel (not a sparc-quad channel)")
    layout = _LAYOUTS.get(cls)
    if layout is not None:
        m = layout.decode(data)  # one struct call for a well-formed fixed-size message
        if m is not None:
            return m
    data = bytes(data)
    expected = cls._get_packed_fingerprint()
    if len(data) < 8:
        raise MessageError(channel, "", f"malformed {type_name(cls)}: {len(data)} bytes, shorter than a "
                                        "fingerprint")
    got = data[:8]
    if got != expected:
        other = _BY_FINGERPRINT.get(got)
        what = (f"a {type_name(other)}" if other is not None
                else "an unknown type (stale or foreign lcm_types?)")
        raise FingerprintError(channel, "", f"wrong fingerprint 0x{got.hex()}: expected {type_name(cls)} "
                                            f"(0x{expected.hex()}), got {what}")
    buf = BytesIO(data)
    try:
        msg = cls.decode(buf)
    except (struct.error, ValueError, UnicodeDecodeError, IndexError) as exc:
        raise MessageError(channel, "", f"malformed {type_name(cls)} ({len(data)} bytes): {exc}") from exc
    if buf.tell() != len(data):
        extra = len(data) - buf.tell()
        raise MessageError(channel, "", f"malformed {type_name(cls)}: {extra} trailing bytes")
    return msg


def _s(utime: int) -> float:
    return utime * 1e-6


def _us(stamp_s: float) -> int:
    return round(stamp_s * 1e6)


# The fast decoders build their dataclasses positionally (keywords cost ~1 us a message in a dataclass
# __init__ with default factories): in these field orders, checked here.
_POSITIONAL = {
    TorsoState: ("q1", "dq1", "ddq1", "ddq1_valid", "quat", "omega", "stamp_s", "seq", "base_accel",
                 "base_accel_valid"),
    SpineCommand: ("mode", "x_d", "dx_d", "ddx_d", "k", "d", "friction_compensation", "tau_ff", "reset",
                   "stamp_s", "seq"),
    MotorFeedback: ("q", "dq", "tau", "temperature_c", "mode", "fault", "load_cell_n", "stamp_s", "seq"),
}
for _cls, _order in _POSITIONAL.items():
    if tuple(f.name for f in fields(_cls)) != _order:
        raise ImportError(f"{_cls.__name__}'s fields changed order: update codec's fast decoders")


# --- per-type decode (validated) ------------------------------------------------------------------
# Each fast decoder: one struct call (`Layout.unpack`), then its `Bounds.check` (one vectorised
# comparison, or the named error). Bytes that are not one well-formed message of the type go to the
# `*_checked` path, whose `decode_raw` names the fingerprint or framing problem.
_TORSO = _LAYOUTS[torso_state_t]
_T_UTIME, _T_SEQ, _T_Q1, _T_DQ1, _T_DDQ1, _T_VALID, _T_QUAT, _T_OMEGA, _T_BACC, _T_BVALID = (
    _TORSO.index(f)[0] for f in ("utime", "seq", "q1", "dq1", "ddq1", "ddq1_valid", "quat", "omega",
                                 "base_accel", "base_accel_valid"))


def _torso_bounds(ddq1_valid: bool, base_accel_valid: bool) -> Bounds:
    on = {"ddq1_valid": ddq1_valid, "base_accel_valid": base_accel_valid}
    return Bounds(torso_state_t, {**HEADER_RANGES, **{k: r for k, r in TORSO_RANGES.items()
                                                      if k not in _TORSO_GATED or on[_TORSO_GATED[k]]}})


# indexed by ddq1_valid + 2 * base_accel_valid
_TORSO_BOUNDS = tuple(_torso_bounds(bool(i & 1), bool(i & 2)) for i in range(4))


def _not_unit(channel: str, norm: float) -> MessageError:
    """The torso quaternion's norm must be 1 to within 10 % (the decoders normalise by it)."""
    return MessageError(channel, "quat", f"norm {norm:.6g} is not 1")


def decode_torso(data: bytes, channel: str = channels.TORSO_STATE) -> TorsoState:
    vals = _TORSO.unpack(data)
    if vals is None:
        return decode_torso_checked(data, channel)
    valid = vals[_T_VALID] != 0
    base_valid = vals[_T_BVALID] != 0
    v = _TORSO_BOUNDS[valid + 2 * base_valid].check(channel, vals)
    a = _T_QUAT
    w, x, y, z = vals[a:a + 4]
    norm = math.sqrt(w * w + x * x + y * y + z * z)
    if not QUAT_NORM_MIN <= norm <= QUAT_NORM_MAX:
        raise _not_unit(channel, norm)
    quat = v[a:a + 4]
    if norm != 1.0:  # x / 1.0 is x: a unit quaternion as sent is kept as it is
        quat /= norm
    return TorsoState(vals[_T_Q1], vals[_T_DQ1], vals[_T_DDQ1] if valid else 0.0, valid, quat,
                      v[_T_OMEGA:_T_OMEGA + 3], _s(vals[_T_UTIME]), vals[_T_SEQ],
                      v[_T_BACC:_T_BACC + 3] if base_valid else np.zeros(3), base_valid)


def decode_torso_checked(data: bytes, channel: str = channels.TORSO_STATE) -> TorsoState:
    """`decode_torso` field by field: the reference, and the path that names what is wrong."""
    m = decode_raw(channel, data, torso_state_t)
    base_valid = bool(m.base_accel_valid)
    v = _TORSO_BOUNDS[bool(m.ddq1_valid) + 2 * base_valid].check_message(channel, m)
    w, x, y, z = m.quat
    norm = math.sqrt(w * w + x * x + y * y + z * z)
    if not QUAT_NORM_MIN <= norm <= QUAT_NORM_MAX:
        raise _not_unit(channel, norm)
    quat = v[_T_QUAT:_T_QUAT + 4]
    quat /= norm
    return TorsoState(q1=m.q1, dq1=m.dq1, ddq1=m.ddq1 if m.ddq1_valid else 0.0, ddq1_valid=bool(m.ddq1_valid),
                      quat=quat, omega=v[_T_OMEGA:_T_OMEGA + 3], stamp_s=_s(m.utime), seq=m.seq,
                      base_accel=v[_T_BACC:_T_BACC + 3] if base_valid else np.zeros(3),
                      base_accel_valid=base_valid)


_ALL_FAULTS = int(sum(f.value for f in Fault if f.value and (f.value & (f.value - 1)) == 0))

_COMMAND = _LAYOUTS[spine_command_t]
_C_UTIME, _C_SEQ, _C_MODE, _C_X_D, _C_DX_D, _C_DDX_D, _C_K, _C_D, _C_FRICTION, _C_TAU_FF, _C_RESET = (
    _COMMAND.index(f)[0] for f in ("utime", "seq", "mode", "x_d", "dx_d", "ddx_d", "k", "d",
                                   "friction_compensation", "tau_ff", "reset"))


# modes that act on x_d (JOINT_TORQUE too: if its commands stop, the node holds x_d in impedance mode)
_TARGET_MODES = frozenset((int(Mode.IMPEDANCE), int(Mode.PD), int(Mode.JOINT_TORQUE)))


class CommandDecoder:
    """Spine commands for one spine: x_d within its reach and, in the modes that use it, inside its
    workspace (a target outside would pin the joints at their limits at full torque: refused, naming x_d).
    The module's `decode_command` is the SPARC module's; a node running another spine model decodes with
    `CommandDecoder(that spine)` (`Inbox.decode_commands_for`)."""

    def __init__(self, spine: params.SpineParams = params.DEFAULT_SPINE) -> None:
        self.workspace = Workspace.of(spine)
        self.bounds = Bounds(spine_command_t, {**HEADER_RANGES, "mode": MODE_RANGE,
                                               **command_ranges(self.workspace.reach_m)})

    def _check_target(self, channel: str, mode: int, x: float, z: float, theta: float) -> None:
        if mode in _TARGET_MODES:
            why = self.workspace.unreachable(x, z, theta)
            if why is not None:
                raise MessageError(channel, "x_d", f"({x:g}, {z:g}, {theta:g}) {why}")

    def __call__(self, data: bytes, channel: str = channels.SPINE_COMMAND) -> SpineCommand:
        vals = _COMMAND.unpack(data)
        if vals is None:
            return self.checked(data, channel)
        v = self.bounds.check(channel, vals)
        self._check_target(channel, vals[_C_MODE], *vals[_C_X_D:_C_X_D + 3])
        return SpineCommand(MODES[vals[_C_MODE]], v[_C_X_D:_C_X_D + 3], v[_C_DX_D:_C_DX_D + 3],
                            v[_C_DDX_D:_C_DDX_D + 3], v[_C_K:_C_K + 3], v[_C_D:_C_D + 3],
                            vals[_C_FRICTION] != 0, v[_C_TAU_FF:_C_TAU_FF + 3], vals[_C_RESET] != 0,
                            _s(vals[_C_UTIME]), vals[_C_SEQ])

    def checked(self, data: bytes, channel: str = channels.SPINE_COMMAND) -> SpineCommand:
        """The decoder field by field: the reference, and the path that names what is wrong."""
        m = decode_raw(channel, data, spine_command_t)
        v = self.bounds.check_message(channel, m)
        self._check_target(channel, m.mode, *m.x_d)
        return SpineCommand(mode=Mode(m.mode), x_d=v[_C_X_D:_C_X_D + 3], dx_d=v[_C_DX_D:_C_DX_D + 3],
                            ddx_d=v[_C_DDX_D:_C_DDX_D + 3], k=v[_C_K:_C_K + 3], d=v[_C_D:_C_D + 3],
                            friction_compensation=bool(m.friction_compensation),
                            tau_ff=v[_C_TAU_FF:_C_TAU_FF + 3], reset=bool(m.reset), stamp_s=_s(m.utime),
                            seq=m.seq)


SPARC_COMMANDS = CommandDecoder()
decode_command = SPARC_COMMANDS.__call__
decode_command_checked = SPARC_COMMANDS.checked


_HEARTBEAT = _LAYOUTS[heartbeat_t]
_H_UTIME, _H_SEQ, _H_SENDER, _H_FAULT, _H_RESET_COUNT, _H_INSTANCE = (
    _HEARTBEAT.index(f)[0] for f in ("utime", "seq", "sender", "fault", "reset_count", "instance"))
_HEARTBEAT_BOUNDS = Bounds(heartbeat_t, HEADER_RANGES)


def decode_heartbeat(data: bytes, channel: str = channels.HEARTBEAT_ROBOT) -> Heartbeat:
    vals = _HEARTBEAT.unpack(data)
    if vals is None:
        return decode_heartbeat_checked(data, channel)
    _HEARTBEAT_BOUNDS.check(channel, vals)
    return Heartbeat(sender=vals[_H_SENDER], fault=vals[_H_FAULT] != 0, reset_count=vals[_H_RESET_COUNT],
                     stamp_s=_s(vals[_H_UTIME]), seq=vals[_H_SEQ], instance=vals[_H_INSTANCE])


def decode_heartbeat_checked(data: bytes, channel: str = channels.HEARTBEAT_ROBOT) -> Heartbeat:
    """`decode_heartbeat` field by field: the reference, and the path that names what is wrong."""
    m = decode_raw(channel, data, heartbeat_t)
    _HEARTBEAT_BOUNDS.check_message(channel, m)
    return Heartbeat(sender=m.sender, fault=bool(m.fault), reset_count=m.reset_count, stamp_s=_s(m.utime),
                     seq=m.seq, instance=m.instance)


_FEEDBACK = _LAYOUTS[motor_feedback_t]
_F_UTIME, _F_SEQ, _F_ANGLE, _F_VELOCITY, _F_TORQUE, _F_TEMPERATURE, _F_MODE, _F_FAULT, _F_LOAD_CELL = (
    _FEEDBACK.index(f)[0] for f in motor_feedback_t.__slots__)
_FEEDBACK_BOUNDS = Bounds(motor_feedback_t, {**HEADER_RANGES, **FEEDBACK_RANGES, "mode": MOTOR_MODE_RANGE})
_FEEDBACK_STRUCT = _FEEDBACK.parts[0][0] if _FEEDBACK.fixed and len(_FEEDBACK.parts) == 1 else None
if _FEEDBACK_STRUCT is None or tuple(motor_feedback_t.__slots__) != (
        "utime", "seq", "angle", "velocity", "torque", "temperature", "mode", "fault", "load_cell"):
    raise RuntimeError("motor_feedback_t changed: update codec's motor feedback fast paths")


def decode_motor_feedback(data: bytes, channel: str = channels.MOTOR_FEEDBACK) -> MotorFeedback:
    """One struct call and one bounds check (every tick of a node over LCM, on the lockstep round trip);
    bytes that are not one well-formed message go through `decode_motor_feedback_checked`."""
    vals = _FEEDBACK.unpack(data)
    if vals is None:
        return decode_motor_feedback_checked(data, channel)
    v = _FEEDBACK_BOUNDS.check(channel, vals)
    return MotorFeedback(v[_F_ANGLE:_F_ANGLE + 3], v[_F_VELOCITY:_F_VELOCITY + 3], v[_F_TORQUE:_F_TORQUE + 3],
                         v[_F_TEMPERATURE:_F_TEMPERATURE + 3],
                         np.array(vals[_F_MODE:_F_MODE + 3], dtype=np.int32),
                         np.array(vals[_F_FAULT:_F_FAULT + 3], dtype=np.int32),
                         v[_F_LOAD_CELL:_F_LOAD_CELL + 2], _s(vals[_F_UTIME]), vals[_F_SEQ])


def decode_motor_feedback_checked(data: bytes, channel: str = channels.MOTOR_FEEDBACK) -> MotorFeedback:
    """`decode_motor_feedback` field by field: the reference, and the path that names what is wrong."""
    m = decode_raw(channel, data, motor_feedback_t)
    _FEEDBACK_BOUNDS.check_message(channel, m)
    return MotorFeedback(q=np.array(m.angle), dq=np.array(m.velocity), tau=np.array(m.torque),
                         temperature_c=np.array(m.temperature), mode=np.array(m.mode, dtype=np.int32),
                         fault=np.array(m.fault, dtype=np.int32), load_cell_n=np.array(m.load_cell),
                         stamp_s=_s(m.utime), seq=m.seq)


_MCMD = _LAYOUTS[motor_command_t]
_M_UTIME, _M_SEQ, _M_FEEDBACK_SEQ, _M_ENABLE, _M_POSITION, _M_VELOCITY, _M_KP, _M_KD, _M_TORQUE = (
    _MCMD.index(f)[0] for f in motor_command_t.__slots__)
_MCMD_BOUNDS = Bounds(motor_command_t, {**HEADER_RANGES, **MOTOR_COMMAND_RANGES})
_MCMD_STRUCT = _MCMD.parts[0][0] if _MCMD.fixed and len(_MCMD.parts) == 1 else None
if _MCMD_STRUCT is None or tuple(motor_command_t.__slots__) != (
        "utime", "seq", "feedback_seq", "enable", "position", "velocity", "kp", "kd", "torque"):
    raise RuntimeError("motor_command_t changed: update codec's motor command fast paths")


def decode_motor_command(data: bytes, channel: str = channels.MOTOR_COMMAND) -> tuple[MotorCommand, int]:
    """Returns (command, feedback_seq it answers; -1 if none). One struct call and one bounds check (the
    robot's end of every lockstep round trip); bytes that are not one well-formed message go through
    `decode_motor_command_checked`."""
    vals = _MCMD.unpack(data)
    if vals is None:
        return decode_motor_command_checked(data, channel)
    v = _MCMD_BOUNDS.check(channel, vals)
    return MotorCommand(tau_ff=v[_M_TORQUE:_M_TORQUE + 3], q_des=v[_M_POSITION:_M_POSITION + 3],
                        dq_des=v[_M_VELOCITY:_M_VELOCITY + 3], kp=v[_M_KP:_M_KP + 3], kd=v[_M_KD:_M_KD + 3],
                        enable=vals[_M_ENABLE] != 0, stamp_s=_s(vals[_M_UTIME]),
                        seq=vals[_M_SEQ]), vals[_M_FEEDBACK_SEQ]


def decode_motor_command_checked(data: bytes, channel: str = channels.MOTOR_COMMAND
                                 ) -> tuple[MotorCommand, int]:
    """`decode_motor_command` field by field: the reference, and the path that names what is wrong."""
    m = decode_raw(channel, data, motor_command_t)
    _MCMD_BOUNDS.check_message(channel, m)
    cmd = MotorCommand(tau_ff=np.array(m.torque), q_des=np.array(m.position), dq_des=np.array(m.velocity),
                       kp=np.array(m.kp), kd=np.array(m.kd), enable=bool(m.enable), stamp_s=_s(m.utime),
                       seq=m.seq)
    return cmd, m.feedback_seq


_STATE = _LAYOUTS[spine_state_t]
_STATE_BOUNDS = Bounds(spine_state_t, {"mode": MODE_RANGE, "requested_mode": MODE_RANGE})
(_S_UTIME, _S_SEQ, _S_MODE, _S_REQUESTED, _S_FAULTS, _S_REJECTED, _S_GAIN_SCALE, _S_PERIOD, _S_JITTER_MAX,
 _S_COMPUTE, _S_FEEDBACK_SEQ, _S_COMMAND_SEQ, _S_TORSO_SEQ) = (
    _STATE.index(f)[0] for f in ("utime", "seq", "mode", "requested_mode", "faults", "rejected",
                                 "gain_scale", "period", "jitter_max", "compute", "feedback_seq",
                                 "command_seq", "torso_seq"))
_S_Q, _S_DQ, _S_TAU_CMD, _S_TAU_EST, _S_X, _S_DX, _S_LOAD_CELL, _S_TEMPERATURE = (
    slice(a, a + n) for a, n in (_STATE.index(f) for f in ("q", "dq", "tau_cmd", "tau_est", "x", "dx",
                                                           "load_cell", "temperature")))


def decode_state(data: bytes, channel: str = channels.SPINE_STATE) -> SpineState:
    """Spine state (for tools and tests, often thousands at a time): fingerprint and length checked,
    modes and fault bits known; values reported as sent. Read by `Layout.unpack`; bytes it does not take
    as one message go through lcm-gen's decode (`decode_raw`), which names the problem."""
    vals = _STATE.unpack(data)
    if vals is None:
        vals = _STATE_BOUNDS.values(decode_raw(channel, data, spine_state_t))
    _STATE_BOUNDS.check(channel, vals)
    faults = vals[_S_FAULTS]
    if faults < 0 or faults & ~_ALL_FAULTS:
        raise MessageError(channel, "faults", f"{faults:#x} has bits that are not faults "
                                              f"(known: {_ALL_FAULTS:#x})")
    return SpineState(stamp_s=_s(vals[_S_UTIME]), seq=vals[_S_SEQ], mode=MODES[vals[_S_MODE]],
                      requested_mode=MODES[vals[_S_REQUESTED]], faults=Fault(faults),
                      rejected=vals[_S_REJECTED], q=np.array(vals[_S_Q], dtype=float),
                      dq=np.array(vals[_S_DQ], dtype=float), tau_cmd=np.array(vals[_S_TAU_CMD], dtype=float),
                      tau_est=np.array(vals[_S_TAU_EST], dtype=float), x=np.array(vals[_S_X], dtype=float),
                      dx=np.array(vals[_S_DX], dtype=float), gain_scale=vals[_S_GAIN_SCALE],
                      load_cell=np.array(vals[_S_LOAD_CELL], dtype=float),
                      temperature=np.array(vals[_S_TEMPERATURE], dtype=float), period=vals[_S_PERIOD],
                      jitter_max=vals[_S_JITTER_MAX], compute=vals[_S_COMPUTE],
                      feedback_seq=vals[_S_FEEDBACK_SEQ], command_seq=vals[_S_COMMAND_SEQ],
                      torso_seq=vals[_S_TORSO_SEQ])


DECODERS = {
    channels.TORSO_STATE: decode_torso,
    channels.SPINE_COMMAND: decode_command,
    channels.SPINE_STATE: decode_state,
    channels.MOTOR_COMMAND: decode_motor_command,
    channels.MOTOR_FEEDBACK: decode_motor_feedback,
    channels.HEARTBEAT_NODE: decode_heartbeat,
    channels.HEARTBEAT_ROBOT: decode_heartbeat,
}


def decode(channel: str, data: bytes):
    """Decode and validate a message of any sparc-quad channel."""
    fn = DECODERS.get(channel)
    if fn is None:
        raise MessageError(channel, "", "unknown channel (not a sparc-quad channel)")
    return fn(data, channel)


# --- encode -----------------------------------------------------------------------------------------
def _l(a, n: int = 3) -> list[float]:
    if type(a) is np.ndarray and a.dtype == np.float64 and a.shape == (n,):
        return a.tolist()
    out = np.asarray(a, dtype=float).tolist()
    if len(out) != n:
        raise ValueError(f"expected {n} values, got {len(out)}")
    return out


_FAST_MISS = (AttributeError, TypeError, struct.error)  # what packing a value of the wrong kind raises
_P = ParamSpec("_P")


def _falls_back_to(checked: Callable[_P, bytes]
                   ) -> Callable[[Callable[_P, bytes | None]], Callable[_P, bytes]]:
    """Wraps a fast encoder (one struct call on the values as they come) that returns None, or raises one
    of `_FAST_MISS`, when they are not what it packs: `checked`, the general path, then gives the same
    bytes, or its error. One hand-over for every fast encoder, so none can fall back differently."""
    def wrap(fast: Callable[_P, bytes | None]) -> Callable[_P, bytes]:
        @functools.wraps(fast)
        def encode(*args: _P.args, **kwargs: _P.kwargs) -> bytes:
            try:
                out = fast(*args, **kwargs)
            except _FAST_MISS:
                out = None
            return checked(*args, **kwargs) if out is None else out
        return encode
    return wrap


_TORSO_STRUCT = _TORSO.parts[0][0] if _TORSO.fixed and len(_TORSO.parts) == 1 else None
if _TORSO_STRUCT is None or tuple(torso_state_t.__slots__) != (
        "utime", "seq", "q1", "dq1", "ddq1", "ddq1_valid", "quat", "omega", "base_accel", "base_accel_valid"):
    raise RuntimeError("torso_state_t changed: update codec.encode_torso's fast path")


def encode_torso_checked(t: TorsoState) -> bytes:
    """`encode_torso` through the generated object: the reference."""
    m = _blank(torso_state_t)
    m.utime, m.seq = _us(t.stamp_s), int(t.seq)
    m.q1, m.dq1, m.ddq1, m.ddq1_valid = float(t.q1), float(t.dq1), float(t.ddq1), bool(t.ddq1_valid)
    m.quat, m.omega = _l(t.quat, 4), _l(t.omega)
    m.base_accel, m.base_accel_valid = _l(t.base_accel), bool(t.base_accel_valid)
    return _encode(m)


@_falls_back_to(encode_torso_checked)
def encode_torso(t: TorsoState) -> bytes | None:
    """The robot's every tick: one struct call when quat, omega and base_accel are 1-D arrays of 4, 3 and
    3 values; anything else takes the general path (same bytes, or its error)."""
    quat, omega, acc = t.quat.tolist(), t.omega.tolist(), t.base_accel.tolist()
    if len(quat) == 4 and len(omega) == 3 and len(acc) == 3:
        return _TORSO.fingerprint + _TORSO_STRUCT.pack(
            _us(t.stamp_s), int(t.seq), float(t.q1), float(t.dq1), float(t.ddq1),
            1 if t.ddq1_valid else 0, *quat, *omega, *acc, 1 if t.base_accel_valid else 0)
    return None


def encode_command(c: SpineCommand) -> bytes:
    m = _blank(spine_command_t)
    m.utime, m.seq, m.mode = _us(c.stamp_s), int(c.seq), int(c.mode)
    m.x_d, m.dx_d, m.ddx_d, m.k, m.d = _l(c.x_d), _l(c.dx_d), _l(c.ddx_d), _l(c.k), _l(c.d)
    m.friction_compensation, m.tau_ff, m.reset = bool(c.friction_compensation), _l(c.tau_ff), bool(c.reset)
    return _encode(m)


def encode_heartbeat(h: Heartbeat) -> bytes:
    m = _blank(heartbeat_t)
    m.utime, m.seq, m.sender, m.fault, m.reset_count = (_us(h.stamp_s), int(h.seq), h.sender, bool(h.fault),
                                                        int(h.reset_count))
    m.instance = int(h.instance)
    return _encode(m)


def encode_motor_feedback_checked(f: MotorFeedback) -> bytes:
    """`encode_motor_feedback` through the generated object: the reference."""
    m = _blank(motor_feedback_t)
    m.utime, m.seq = _us(f.stamp_s), int(f.seq)
    m.angle, m.velocity, m.torque, m.temperature = _l(f.q), _l(f.dq), _l(f.tau), _l(f.temperature_c)
    m.mode = [int(v) for v in np.asarray(f.mode).reshape(3)]
    m.fault = [int(v) for v in np.asarray(f.fault).reshape(3)]
    m.load_cell = _l(f.load_cell_n, 2)
    return _encode(m)


@_falls_back_to(encode_motor_feedback_checked)
def encode_motor_feedback(f: MotorFeedback) -> bytes | None:
    """The robot's every tick: one struct call when the fields are 1-D arrays of the right lengths (float
    vectors, integer mode/fault); anything else takes the general path (same bytes, or its error)."""
    q, dq, tau, temp = f.q.tolist(), f.dq.tolist(), f.tau.tolist(), f.temperature_c.tolist()
    mode, fault, cell = f.mode.tolist(), f.fault.tolist(), f.load_cell_n.tolist()
    if (len(q) == 3 and len(dq) == 3 and len(tau) == 3 and len(temp) == 3 and len(mode) == 3
            and len(fault) == 3 and len(cell) == 2 and f.mode.dtype.kind in "iu"
            and f.fault.dtype.kind in "iu"):
        return _FEEDBACK.fingerprint + _FEEDBACK_STRUCT.pack(
            _us(f.stamp_s), int(f.seq), *q, *dq, *tau, *temp, *mode, *fault, *cell)
    return None


def encode_motor_command_checked(c: MotorCommand, feedback_seq: int = -1) -> bytes:
    """`encode_motor_command` through the generated object: the reference."""
    m = _blank(motor_command_t)
    m.utime, m.seq, m.feedback_seq, m.enable = _us(c.stamp_s), int(c.seq), int(feedback_seq), bool(c.enable)
    m.position, m.velocity, m.kp, m.kd, m.torque = _l(c.q_des), _l(c.dq_des), _l(c.kp), _l(c.kd), _l(c.tau_ff)
    return _encode(m)


@_falls_back_to(encode_motor_command_checked)
def encode_motor_command(c: MotorCommand, feedback_seq: int = -1) -> bytes | None:
    """The node's every tick over LCM: one struct call when the arrays are 1-D of length 3; anything else
    takes the general path (same bytes, or its error)."""
    pos, vel, kp, kd, tau = (c.q_des.tolist(), c.dq_des.tolist(), c.kp.tolist(), c.kd.tolist(),
                             c.tau_ff.tolist())
    if len(pos) == 3 and len(vel) == 3 and len(kp) == 3 and len(kd) == 3 and len(tau) == 3:
        return _MCMD.fingerprint + _MCMD_STRUCT.pack(_us(c.stamp_s), int(c.seq), int(feedback_seq),
                                                     1 if c.enable else 0, *pos, *vel, *kp, *kd, *tau)
    return None


if tuple(spine_state_t.__slots__) != (
        "utime", "seq", "mode", "requested_mode", "faults", "rejected", "q", "dq", "tau_cmd", "tau_est", "x",
        "dx", "gain_scale", "load_cell", "temperature", "period", "jitter_max", "compute", "feedback_seq",
        "command_seq", "torso_seq") or [st is None for st, _, _ in _STATE.parts] != [False, True, False]:
    raise RuntimeError("spine_state_t changed: update codec.encode_state's field order")
_STATE_HEAD, _STATE_TAIL = _STATE.parts[0][0], _STATE.parts[2][0]  # the runs before and after `rejected`
_U32 = struct.Struct(">I")
# the usual state, with nothing rejected: head, the empty string (length 1, its NUL) and tail in one struct
_STATE_NOTHING_REJECTED = struct.Struct(
    ">" + _STATE_HEAD.format.lstrip(">") + "Ix" + _STATE_TAIL.format.lstrip(">"))


def encode_state_checked(s: SpineState) -> bytes:
    """`encode_state` value by value (lists, integer arrays): every field converted and its length checked
    (a wrong one is a ValueError), then the layout's `pack`."""
    return _STATE.pack([
        _us(s.stamp_s), int(s.seq), int(s.mode), int(s.requested_mode), int(s.faults), s.rejected,
        *_l(s.q, 4), *_l(s.dq, 4), *_l(s.tau_cmd), *_l(s.tau_est), *_l(s.x), *_l(s.dx), float(s.gain_scale),
        *_l(s.load_cell, 2), *_l(s.temperature), float(s.period), float(s.jitter_max), float(s.compute),
        int(s.feedback_seq), int(s.command_seq), int(s.torso_seq)])


@_falls_back_to(encode_state_checked)
def encode_state(s: SpineState) -> bytes | None:
    """spine_state_t's bytes straight from the fields (slot order checked at import), with the layout's
    precompiled structs: no generated object in between. The node's own state is float64 arrays of the
    right lengths, one tolist each; lists, nested or odd values take `encode_state_checked`."""
    q, dq, tau_cmd, tau_est = s.q.tolist(), s.dq.tolist(), s.tau_cmd.tolist(), s.tau_est.tolist()
    x, dx, load_cell = s.x.tolist(), s.dx.tolist(), s.load_cell.tolist()
    temperature = s.temperature.tolist()
    if (len(q) == 4 and len(dq) == 4 and len(tau_cmd) == 3 and len(tau_est) == 3 and len(x) == 3
            and len(dx) == 3 and len(load_cell) == 2 and len(temperature) == 3):
        head = (_us(s.stamp_s), int(s.seq), int(s.mode), int(s.requested_mode), int(s.faults))
        tail = (*q, *dq, *tau_cmd, *tau_est, *x, *dx, float(s.gain_scale), *load_cell, *temperature,
                float(s.period), float(s.jitter_max), float(s.compute), int(s.feedback_seq),
                int(s.command_seq), int(s.torso_seq))
        rejected = s.rejected
        if not rejected:  # the usual state: one struct, the empty string's length 1 in it
            return _STATE.fingerprint + _STATE_NOTHING_REJECTED.pack(*head, 1, *tail)
        rejected = rejected.encode("utf-8")
        return b"".join((_STATE.fingerprint, _STATE_HEAD.pack(*head), _U32.pack(len(rejected) + 1), rejected,
                         b"\0", _STATE_TAIL.pack(*tail)))
    return None
