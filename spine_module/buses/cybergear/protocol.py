"""The Xiaomi CyberGear CAN protocol: frame ids, communication types, parameters, scaling.

Sources (facts only, no code taken): the CyberGear micromotor instruction manual, section 4 ("Driver
communication protocol"), and its public English translation (github belovictor/cybergear-docs).

Frame layout (CAN 2.0B, 1 Mbit/s, 29-bit extended id, always 8 data bytes on the wire from the motor):

    bits 28..24  communication type
    bits 23..8   data area 2 (host -> motor: bits 15..8 host id; type 1: torque; type 7: new id in 23..16;
                 motor -> host: bits 15..8 motor id, type 2 adds fault bits 21..16 and mode bits 23..22)
    bits  7..0   target address (motor id, host id, or 0xFE for a type-0 reply)

Host -> motor types: 0 get id, 1 operation control, 3 enable, 4 stop (byte 0 = 1 also clears faults),
6 set mechanical zero (byte 0 = 1), 7 set CAN id, 17 read parameter, 18 write parameter.
Motor -> host types: 0 device id reply (64-bit MCU uid), 2 feedback, 17 read reply, 21 fault frame.

INTERPRETATION (type 21): the translated manual lists the request-style id (host id in 15..8, motor id
as target) for the fault frame, which the motor sends. We encode it like every other motor -> host frame
(motor id in 15..8, host id as target) and the decoder accepts both orders. Its two 32-bit words (fault
value, warning value) are little-endian like every other multi-byte parameter of the firmware.

Scaling: uint16 over a range, clamped before scaling, truncated like the manual's sample code. The
position range is +-4*pi in the manual's tables and +-12.5 rad in its sample code and in most drivers;
it is a setting here (`Ranges.position_max`), default 12.5 so that frames match other drivers.
"""

from __future__ import annotations

import math
import struct
from dataclasses import dataclass, field
from enum import IntEnum

import can

from spine_module.params import CYBERGEAR

ID_MASK_29 = 0x1FFFFFFF
BROADCAST_REPLY_TARGET = 0xFE  # target of a type-0 reply
FACTORY_MOTOR_ID = 0x7F
DEFAULT_HOST_ID = 0xFD
FRAME_DLC = 8


class CommType(IntEnum):
    GET_ID = 0
    OPERATION_CONTROL = 1
    FEEDBACK = 2
    ENABLE = 3
    STOP = 4
    SET_ZERO = 6
    SET_CAN_ID = 7
    PARAM_READ = 17
    PARAM_WRITE = 18
    FAULT = 21


class MotorMode(IntEnum):
    """Mode bits 23..22 of a feedback frame."""

    RESET = 0
    CALIBRATION = 1
    RUN = 2


class RunMode(IntEnum):
    """Values of the run_mode parameter (0x7005)."""

    OPERATION = 0
    POSITION = 1
    SPEED = 2
    CURRENT = 3


class FeedbackFault(IntEnum):
    """Fault bits of a feedback frame: bit positions within the id's bits 21..16 (0 = id bit 16)."""

    UNDERVOLTAGE = 0
    OVERCURRENT = 1
    OVER_TEMPERATURE = 2
    MAGNETIC_ENCODER = 3
    HALL_ENCODER = 4
    NOT_CALIBRATED = 5


FAULT_VALUE_BITS = {  # type-21 fault word
    0: "motor over-temperature",
    1: "driver chip fault",
    2: "undervoltage",
    3: "overvoltage",
    4: "phase B current sampling overcurrent",
    5: "phase C current sampling overcurrent",
    7: "encoder not calibrated",
    16: "phase A current sampling overcurrent",
}
FAULT_OVERLOAD_MASK = 0x0000FF00  # bits 15..8: overload fault
WARNING_VALUE_BITS = {0: "motor over-temperature warning"}


def describe_feedback_faults(bits: int) -> list[str]:
    return [f.name.lower().replace("_", " ") for f in FeedbackFault if bits >> f.value & 1]


def describe_fault_value(value: int) -> list[str]:
    names = [name for bit, name in FAULT_VALUE_BITS.items() if value >> bit & 1]
    if value & FAULT_OVERLOAD_MASK:
        names.append(f"overload ({(value & FAULT_OVERLOAD_MASK) >> 8:#04x})")
    return names


# --- parameters (types 17 / 18) ------------------------------------------------------------------------
@dataclass(frozen=True)
class ParamSpec:
    index: int
    name: str
    fmt: str  # struct code, little-endian, value in bytes 4.. of the frame
    lo: float | None
    hi: float | None
    writable: bool
    unit: str = ""


# CAN_TIMEOUT, the firmware's own CAN watchdog (no host frame for this long: the motor leaves run mode).
# Source: the CyberGear instruction manual, section 3.3.3 "Parameter list" (debugger parameter table; public
# English translation github belovictor/cybergear-docs, instructionmanual.md): "0x200c CAN_TIMEOUT uint32
# read/write, max 100000, min 0, current value 0, can timeout threshold, default 0". That table gives no
# unit and section 4's type-17/18 list (0x7005-0x7020) does not list it: reading and writing 0x200C with
# types 17/18 is what public drivers of the same firmware family do (RobStride's 0x20xx table through the
# same frames), NOT confirmed on a CyberGear here. The unit is taken from RobStride's manual, whose
# CAN_TIMEOUT note reads "20000 = 1 s" (50 us ticks): ASSUMED for the CyberGear, check on the first motor
# (`sparc-quad motors status` prints the read-back). Because of both doubts the driver reads the value
# back and refuses to run when it does not match; docs/cybergear.md describes the watchdog fallback.
CAN_TIMEOUT_INDEX = 0x200C
CAN_TIMEOUT_TICKS_PER_S = CYBERGEAR.can_timeout_ticks_per_s
CAN_TIMEOUT_MAX_TICKS = CYBERGEAR.can_timeout_max_ticks
_I, _V, _T = CYBERGEAR.current_a, CYBERGEAR.velocity_rad_s, CYBERGEAR.torque_nm

PARAMS: tuple[ParamSpec, ...] = (
    ParamSpec(CAN_TIMEOUT_INDEX, "CAN_TIMEOUT", "I", 0, CAN_TIMEOUT_MAX_TICKS, True,
              f"1/{CAN_TIMEOUT_TICKS_PER_S} s"),
    ParamSpec(0x7005, "run_mode", "B", 0, 3, True),
    ParamSpec(0x7006, "iq_ref", "f", -_I, _I, True, "A"),
    ParamSpec(0x700A, "spd_ref", "f", -_V, _V, True, "rad/s"),
    ParamSpec(0x700B, "limit_torque", "f", 0.0, _T, True, "N*m"),
    ParamSpec(0x7010, "cur_kp", "f", None, None, True),
    ParamSpec(0x7011, "cur_ki", "f", None, None, True),
    ParamSpec(0x7014, "cur_filt_gain", "f", 0.0, 1.0, True),
    ParamSpec(0x7016, "loc_ref", "f", None, None, True, "rad"),
    ParamSpec(0x7017, "limit_spd", "f", 0.0, _V, True, "rad/s"),
    ParamSpec(0x7018, "limit_cur", "f", 0.0, _I, True, "A"),
    ParamSpec(0x7019, "mechPos", "f", None, None, False, "rad"),
    ParamSpec(0x701A, "iqf", "f", None, None, False, "A"),
    ParamSpec(0x701B, "mechVel", "f", None, None, False, "rad/s"),
    ParamSpec(0x701C, "VBUS", "f", None, None, False, "V"),
    ParamSpec(0x701D, "rotation", "h", None, None, True, "turns"),
    ParamSpec(0x701E, "loc_kp", "f", None, None, True),
    ParamSpec(0x701F, "spd_kp", "f", None, None, True),
    ParamSpec(0x7020, "spd_ki", "f", None, None, True),
)
PARAM_BY_INDEX: dict[int, ParamSpec] = {p.index: p for p in PARAMS}
PARAM_BY_NAME: dict[str, ParamSpec] = {p.name: p for p in PARAMS}


def param_spec(key: int | str) -> ParamSpec:
    table = PARAM_BY_NAME if isinstance(key, str) else PARAM_BY_INDEX
    try:
        return table[key]  # type: ignore[index]
    except KeyError:
        raise ValueError(f"unknown CyberGear parameter {key!r}") from None


# --- scaling -------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Ranges:
    """Ranges of the uint16 fields of types 1 and 2 (defaults: `spine_module.params.CYBERGEAR`)."""

    position_max: float = CYBERGEAR.position_rad  # rad; 4*pi per the manual's tables (module docstring)
    velocity_max: float = CYBERGEAR.velocity_rad_s  # rad/s
    torque_max: float = CYBERGEAR.torque_nm  # N*m
    kp_max: float = CYBERGEAR.kp_nm_rad  # N*m/rad
    kd_max: float = CYBERGEAR.kd_nm_s_rad  # N*m*s/rad


DEFAULT_RANGES = Ranges()
MANUAL_TABLE_RANGES = Ranges(position_max=CYBERGEAR.position_table_rad)
U16_MAX = 0xFFFF


def float_to_u16(x: float, lo: float, hi: float) -> int:
    """Clamp x to [lo, hi], then scale to 0..65535 (truncating). Non-finite input raises ValueError."""
    if not math.isfinite(x):
        raise ValueError(f"cannot encode non-finite value {x!r}")
    x = min(max(x, lo), hi)
    return int((x - lo) * U16_MAX / (hi - lo))


def u16_to_float(u: int, lo: float, hi: float) -> float:
    return lo + u * (hi - lo) / U16_MAX


# --- ids -----------------------------------------------------------------------------------------------
def make_id(comm_type: int, data2: int, target: int) -> int:
    if not 0 <= comm_type <= 0x1F or not 0 <= data2 <= 0xFFFF or not 0 <= target <= 0xFF:
        raise ValueError(f"id field out of range: type={comm_type} data2={data2:#x} target={target:#x}")
    return (comm_type << 24) | (data2 << 8) | target


def split_id(arbitration_id: int) -> tuple[int, int, int]:
    """(communication type, data area 2, target) of a 29-bit id."""
    return (arbitration_id >> 24) & 0x1F, (arbitration_id >> 8) & 0xFFFF, arbitration_id & 0xFF


def _check_id(name: str, value: int) -> None:
    if not 0 <= value <= 0xFF:
        raise ValueError(f"{name} must be 0..255, got {value}")


def _msg(comm_type: int, data2: int, target: int, data: bytes) -> can.Message:
    return can.Message(arbitration_id=make_id(comm_type, data2, target), data=data, is_extended_id=True,
                       dlc=len(data))


# --- frames --------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Frame:
    """Base of every decoded frame: the motor it concerns and the host id it carries."""

    motor_id: int
    host_id: int


@dataclass(frozen=True)
class GetId(Frame):
    pass


@dataclass(frozen=True)
class DeviceId(Frame):
    uid: bytes = b"\0" * 8


@dataclass(frozen=True)
class OperationControl(Frame):
    torque: float = 0.0
    position: float = 0.0
    velocity: float = 0.0
    kp: float = 0.0
    kd: float = 0.0
    raw: tuple[int, int, int, int, int] = (0, 0, 0, 0, 0)  # torque, position, velocity, kp, kd as uint16


@dataclass(frozen=True)
class Feedback(Frame):
    position: float = 0.0
    velocity: float = 0.0
    torque: float = 0.0
    temperature_c: float = 0.0
    mode: int = 0
    fault_bits: int = 0  # bits 21..16 of the id, shifted down (see FeedbackFault)


@dataclass(frozen=True)
class Enable(Frame):
    pass


@dataclass(frozen=True)
class Stop(Frame):
    clear_fault: bool = False


@dataclass(frozen=True)
class SetZero(Frame):
    pass


@dataclass(frozen=True)
class SetCanId(Frame):
    new_id: int = 0


@dataclass(frozen=True)
class ParamRead(Frame):
    index: int = 0


@dataclass(frozen=True)
class ParamReadReply(Frame):
    index: int = 0
    value: float | int = 0
    ok: bool = True  # id bits 23..16: 0 success, 1 failure


@dataclass(frozen=True)
class ParamWrite(Frame):
    index: int = 0
    value: float | int = 0


@dataclass(frozen=True)
class FaultFrame(Frame):
    fault_value: int = 0
    warning_value: int = 0
    descriptions: tuple[str, ...] = field(default=())


# --- encoders (host -> motor) ----------------------------------------------------------------------------
def encode_get_id(motor_id: int, host_id: int = DEFAULT_HOST_ID) -> can.Message:
    _check_id("motor_id", motor_id), _check_id("host_id", host_id)
    return _msg(CommType.GET_ID, host_id, motor_id, bytes(8))


def encode_operation_control(motor_id: int, torque: float, position: float, velocity: float, kp: float,
                             kd: float, ranges: Ranges = DEFAULT_RANGES) -> can.Message:
    """Type 1. Values are clamped to their ranges before scaling; NaN/inf raise ValueError."""
    _check_id("motor_id", motor_id)
    r = ranges
    t = float_to_u16(torque, -r.torque_max, r.torque_max)
    data = struct.pack(">4H", float_to_u16(position, -r.position_max, r.position_max),
                       float_to_u16(velocity, -r.velocity_max, r.velocity_max),
                       float_to_u16(kp, 0.0, r.kp_max), float_to_u16(kd, 0.0, r.kd_max))
    return _msg(CommType.OPERATION_CONTROL, t, motor_id, data)


def encode_enable(motor_id: int, host_id: int = DEFAULT_HOST_ID) -> can.Message:
    _check_id("motor_id", motor_id), _check_id("host_id", host_id)
    return _msg(CommType.ENABLE, host_id, motor_id, bytes(8))


def encode_stop(motor_id: int, host_id: int = DEFAULT_HOST_ID, clear_fault: bool = False) -> can.Message:
    _check_id("motor_id", motor_id), _check_id("host_id", host_id)
    return _msg(CommType.STOP, host_id, motor_id, bytes([1 if clear_fault else 0]) + bytes(7))


def encode_set_zero(motor_id: int, host_id: int = DEFAULT_HOST_ID) -> can.Message:
    _check_id("motor_id", motor_id), _check_id("host_id", host_id)
    return _msg(CommType.SET_ZERO, host_id, motor_id, bytes([1]) + bytes(7))


def encode_set_can_id(motor_id: int, new_id: int, host_id: int = DEFAULT_HOST_ID) -> can.Message:
    _check_id("motor_id", motor_id), _check_id("host_id", host_id)
    if not 1 <= new_id <= 0x7F:
        raise ValueError(f"new CAN id must be 1..127, got {new_id}")
    return _msg(CommType.SET_CAN_ID, (new_id << 8) | host_id, motor_id, bytes([1]) + bytes(7))


def encode_param_value(spec: ParamSpec, value: float | int) -> bytes:
    """Four little-endian value bytes; clamps to the parameter's range; non-finite raises ValueError."""
    if spec.fmt == "f":
        v = float(value)
        if not math.isfinite(v):
            raise ValueError(f"{spec.name}: cannot encode non-finite value {value!r}")
        if spec.lo is not None and spec.hi is not None:
            v = min(max(v, spec.lo), spec.hi)
        return struct.pack("<f", v)
    v = int(value)
    if spec.lo is not None and spec.hi is not None:
        v = int(min(max(v, spec.lo), spec.hi))
    return struct.pack("<" + spec.fmt, v).ljust(4, b"\0")


def encode_param_write(motor_id: int, key: int | str, value: float | int,
                       host_id: int = DEFAULT_HOST_ID) -> can.Message:
    _check_id("motor_id", motor_id), _check_id("host_id", host_id)
    spec = param_spec(key)
    if not spec.writable:
        raise ValueError(f"parameter {spec.name} is read-only")
    data = struct.pack("<HH", spec.index, 0) + encode_param_value(spec, value)
    return _msg(CommType.PARAM_WRITE, host_id, motor_id, data)


def encode_param_read(motor_id: int, key: int | str, host_id: int = DEFAULT_HOST_ID) -> can.Message:
    _check_id("motor_id", motor_id), _check_id("host_id", host_id)
    spec = param_spec(key)
    return _msg(CommType.PARAM_READ, host_id, motor_id, struct.pack("<HH", spec.index, 0) + bytes(4))


# --- encoders (motor -> host), used by the emulator ------------------------------------------------------
def encode_device_id(motor_id: int, uid: bytes) -> can.Message:
    _check_id("motor_id", motor_id)
    if len(uid) != 8:
        raise ValueError("uid must be 8 bytes")
    return _msg(CommType.GET_ID, motor_id, BROADCAST_REPLY_TARGET, bytes(uid))


def encode_feedback(motor_id: int, host_id: int, position: float, velocity: float, torque: float,
                    temperature_c: float, mode: int = MotorMode.RUN, fault_bits: int = 0,
                    ranges: Ranges = DEFAULT_RANGES) -> can.Message:
    _check_id("motor_id", motor_id), _check_id("host_id", host_id)
    if not 0 <= mode <= 3 or not 0 <= fault_bits <= 0x3F:
        raise ValueError("mode must be 0..3 and fault_bits 0..0x3f")
    r = ranges
    temp = round(min(max(temperature_c * 10.0, 0.0), U16_MAX))
    data = struct.pack(">4H", float_to_u16(position, -r.position_max, r.position_max),
                       float_to_u16(velocity, -r.velocity_max, r.velocity_max),
                       float_to_u16(torque, -r.torque_max, r.torque_max), temp)
    data2 = (mode << 14) | (fault_bits << 8) | motor_id
    return _msg(CommType.FEEDBACK, data2, host_id, data)


def encode_param_read_reply(motor_id: int, host_id: int, key: int | str, value: float | int,
                            ok: bool = True) -> can.Message:
    spec = param_spec(key)
    data = struct.pack("<HH", spec.index, 0) + encode_param_value(spec, value)
    return _msg(CommType.PARAM_READ, ((0 if ok else 1) << 8) | motor_id, host_id, data)


def encode_fault(motor_id: int, host_id: int, fault_value: int, warning_value: int = 0) -> can.Message:
    _check_id("motor_id", motor_id), _check_id("host_id", host_id)
    return _msg(CommType.FAULT, motor_id, host_id, struct.pack("<II", fault_value, warning_value))


# --- decoders ------------------------------------------------------------------------------------------
class FrameError(ValueError):
    """A frame that is not a valid CyberGear frame for this receiver; `reason` says why."""

    def __init__(self, reason: str, msg: can.Message | None = None) -> None:
        self.reason = reason
        self.msg = msg
        where = f" (id {msg.arbitration_id:#010x}, dlc {msg.dlc})" if msg is not None else ""
        super().__init__(reason + where)


_MIN_DLC_TO_MOTOR = {
    CommType.GET_ID: 0, CommType.OPERATION_CONTROL: 8, CommType.ENABLE: 0, CommType.STOP: 0,
    CommType.SET_ZERO: 0, CommType.SET_CAN_ID: 0, CommType.PARAM_READ: 2, CommType.PARAM_WRITE: 5,
}
_MIN_DLC_TO_HOST = {CommType.GET_ID: 8, CommType.FEEDBACK: 8, CommType.PARAM_READ: 5, CommType.FAULT: 8}


def _basic_checks(msg: can.Message) -> tuple[int, int, int]:
    if msg.is_error_frame:
        raise FrameError("error frame", msg)
    if msg.is_remote_frame:
        raise FrameError("remote frame", msg)
    if not msg.is_extended_id:
        raise FrameError("standard 11-bit id; CyberGear uses 29-bit extended ids", msg)
    if getattr(msg, "is_fd", False):
        raise FrameError("CAN FD frame", msg)
    if msg.arbitration_id > ID_MASK_29 or msg.arbitration_id < 0:
        raise FrameError("id wider than 29 bits", msg)
    if len(msg.data) != msg.dlc and not (msg.dlc == 0 and msg.data is None):
        raise FrameError(f"dlc {msg.dlc} does not match {len(msg.data)} data bytes", msg)
    if msg.dlc > 8:
        raise FrameError(f"dlc {msg.dlc} > 8", msg)
    return split_id(msg.arbitration_id)


def _decode_param_value(spec: ParamSpec, raw: bytes) -> float | int:
    size = struct.calcsize(spec.fmt)
    if len(raw) < size:
        raise FrameError(f"parameter {spec.name} needs {size} value bytes, got {len(raw)}")
    return struct.unpack("<" + spec.fmt, raw[:size])[0]


def decode_from_motor(msg: can.Message, host_id: int | None = None, motor_ids: set[int] | None = None,
                      ranges: Ranges = DEFAULT_RANGES) -> Frame:
    """Decode a motor -> host frame (types 0, 2, 17, 21). Raises FrameError with the reason otherwise.

    `host_id`: reject frames addressed to another host. `motor_ids`: reject frames from other motors.
    """
    comm, data2, target = _basic_checks(msg)
    if comm not in _MIN_DLC_TO_HOST:
        raise FrameError(f"communication type {comm} is not a motor -> host type", msg)
    need = _MIN_DLC_TO_HOST[comm]
    if msg.dlc < need:
        raise FrameError(f"type {comm} needs {need} data bytes, got {msg.dlc}", msg)
    data = bytes(msg.data)
    motor_id = data2 & 0xFF
    if comm == CommType.FAULT and host_id is not None and target != host_id and motor_id == host_id:
        motor_id, target = target, motor_id  # request-style layout of the translated manual
    if comm == CommType.GET_ID:
        if target != BROADCAST_REPLY_TARGET:
            raise FrameError(f"type 0 reply must target {BROADCAST_REPLY_TARGET:#x}, got {target:#x}", msg)
    elif host_id is not None and target != host_id:
        raise FrameError(f"addressed to host {target:#x}, this host is {host_id:#x}", msg)
    if motor_ids is not None and motor_id not in motor_ids:
        raise FrameError(f"from motor {motor_id} which is not configured", msg)
    if comm == CommType.GET_ID:
        return DeviceId(motor_id, host_id if host_id is not None else 0, uid=data[:8])
    if comm == CommType.FEEDBACK:
        r = ranges
        p, v, t, temp = struct.unpack(">4H", data[:8])
        return Feedback(motor_id, target,
                        position=u16_to_float(p, -r.position_max, r.position_max),
                        velocity=u16_to_float(v, -r.velocity_max, r.velocity_max),
                        torque=u16_to_float(t, -r.torque_max, r.torque_max),
                        temperature_c=temp / 10.0, mode=(data2 >> 14) & 0x3, fault_bits=(data2 >> 8) & 0x3F)
    if comm == CommType.PARAM_READ:
        index = struct.unpack("<H", data[:2])[0]
        if index not in PARAM_BY_INDEX:
            raise FrameError(f"read reply for unknown parameter {index:#06x}", msg)
        ok = (data2 >> 8) == 0
        spec = PARAM_BY_INDEX[index]
        value = _decode_param_value(spec, data[4:]) if ok else 0
        if ok and not (math.isfinite(value) and (spec.lo is None or spec.lo <= value)
                       and (spec.hi is None or value <= spec.hi)):
            raise FrameError(f"read reply for {spec.name}: value {value!r} is not a finite number in "
                             f"[{spec.lo}, {spec.hi}]", msg)
        return ParamReadReply(motor_id, target, index=index, value=value, ok=ok)
    fault_value, warning_value = struct.unpack("<II", data[:8])
    return FaultFrame(motor_id, target, fault_value=fault_value, warning_value=warning_value,
                      descriptions=tuple(describe_fault_value(fault_value)))


def decode_to_motor(msg: can.Message, motor_ids: set[int] | None = None,
                    ranges: Ranges = DEFAULT_RANGES) -> Frame:
    """Decode a host -> motor frame (types 0, 1, 3, 4, 6, 7, 17, 18), as the firmware would.

    `motor_ids`: the ids this receiver answers for; frames to other targets are rejected.
    """
    comm, data2, target = _basic_checks(msg)
    if comm not in _MIN_DLC_TO_MOTOR:
        raise FrameError(f"communication type {comm} is not a host -> motor type", msg)
    if motor_ids is not None and target not in motor_ids:
        raise FrameError(f"addressed to motor {target}, not one of {sorted(motor_ids)}", msg)
    need = _MIN_DLC_TO_MOTOR[comm]
    if msg.dlc < need:
        raise FrameError(f"type {comm} needs {need} data bytes, got {msg.dlc}", msg)
    data = bytes(msg.data) if msg.data is not None else b""
    host_id = data2 & 0xFF
    if comm == CommType.OPERATION_CONTROL:
        r = ranges
        p, v, kp, kd = struct.unpack(">4H", data[:8])
        return OperationControl(target, 0,
                                torque=u16_to_float(data2, -r.torque_max, r.torque_max),
                                position=u16_to_float(p, -r.position_max, r.position_max),
                                velocity=u16_to_float(v, -r.velocity_max, r.velocity_max),
                                kp=u16_to_float(kp, 0.0, r.kp_max), kd=u16_to_float(kd, 0.0, r.kd_max),
                                raw=(data2, p, v, kp, kd))
    if comm == CommType.GET_ID:
        return GetId(target, host_id)
    if comm == CommType.ENABLE:
        return Enable(target, host_id)
    if comm == CommType.STOP:
        return Stop(target, host_id, clear_fault=bool(data[:1] == b"\x01"))
    if comm == CommType.SET_ZERO:
        return SetZero(target, host_id)
    if comm == CommType.SET_CAN_ID:
        new_id = data2 >> 8
        if not 1 <= new_id <= 0x7F:
            raise FrameError(f"new CAN id {new_id} outside 1..127", msg)
        return SetCanId(target, host_id, new_id=new_id)
    index = struct.unpack("<H", data[:2])[0]
    if index not in PARAM_BY_INDEX:
        raise FrameError(f"unknown parameter index {index:#06x}", msg)
    if comm == CommType.PARAM_READ:
        return ParamRead(target, host_id, index=index)
    spec = PARAM_BY_INDEX[index]
    try:
        value = _decode_param_value(spec, data[4:])
    except FrameError as e:
        raise FrameError(e.reason, msg) from None
    if isinstance(value, float) and not math.isfinite(value):
        raise FrameError(f"non-finite value for {spec.name}", msg)
    return ParamWrite(target, host_id, index=index, value=value)
