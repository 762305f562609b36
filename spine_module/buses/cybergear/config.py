"""Per-joint configuration of the CyberGear backend, read from one TOML file a user edits.

Joint-side quantities (what the node sees) relate to the motor's output-shaft quantities (what the frames
carry; the CyberGear's 7.75:1 gearbox is inside the motor, its frames are already output-side) by

    q_joint   = direction * (q_motor - zero_offset_rad) / gear_ratio
    dq_joint  = direction * dq_motor / gear_ratio
    tau_joint = direction * tau_motor * gear_ratio * torque_scale

`gear_ratio` is any transmission between the motor's output shaft and the joint (1 on the SPARC spine);
`torque_scale` corrects the motor's torque estimate if a bench calibration says so (1 by default).

Joints are matched by `name` (q2, q3, q4: `params.ACTUATED_JOINTS`), never by their order in the file: the
config keeps them in the node's joint order, so joint i's torque always goes to that joint's CAN id.
Every value is checked when the file is read (`ConfigError` names the file, the table and the field).
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, field, replace
from pathlib import Path

from spine_module.buses.cybergear.protocol import (
    CAN_TIMEOUT_MAX_TICKS,
    CAN_TIMEOUT_TICKS_PER_S,
    DEFAULT_HOST_ID,
    Ranges,
)
from spine_module.params import ACTUATED_JOINTS, CYBERGEAR, JOINT_LOWER_RAD, JOINT_UPPER_RAD

DEFAULT_CONFIG_PATH = Path(__file__).with_name("motors.toml")

# Output-side torque per ampere of iq. The manual gives a torque constant of 0.87 N*m/Arms; iq is a peak
# (amplitude) current, so per ampere of iq it is 0.87/sqrt(2) = 0.615 N*m/A. Check: the manual's rated
# 4 N*m at 6.5 A peak gives 0.615 N*m/A.
KT_NM_PER_A = 0.87 / math.sqrt(2.0)


@dataclass(frozen=True)
class JointConfig:
    name: str
    can_id: int
    direction: int = 1  # +1 or -1
    zero_offset_rad: float = 0.0  # motor position (rad) at which the joint angle is zero
    gear_ratio: float = 1.0
    torque_scale: float = 1.0

    def __post_init__(self) -> None:
        for f in ("zero_offset_rad", "gear_ratio", "torque_scale"):
            if not math.isfinite(getattr(self, f)):
                raise ValueError(f"{self.name}: {f} must be finite, got {getattr(self, f)}")
        if self.direction not in (1, -1):
            raise ValueError(f"{self.name}: direction must be +1 or -1, got {self.direction}")
        if not 1 <= self.can_id <= 0x7F:
            raise ValueError(f"{self.name}: can_id must be 1..127, got {self.can_id}")
        if not (self.gear_ratio > 0 and self.torque_scale > 0):
            raise ValueError(f"{self.name}: gear_ratio and torque_scale must be > 0")
        for f, (lo, hi, why) in JOINT_RANGES.items():
            _check(f"{self.name}: {f}", getattr(self, f), lo, hi, why)

    # joint <-> motor
    def q_to_motor(self, q: float) -> float:
        return self.direction * q * self.gear_ratio + self.zero_offset_rad

    def q_from_motor(self, p: float) -> float:
        return self.direction * (p - self.zero_offset_rad) / self.gear_ratio

    def dq_to_motor(self, dq: float) -> float:
        return self.direction * dq * self.gear_ratio

    def dq_from_motor(self, v: float) -> float:
        return self.direction * v / self.gear_ratio

    def tau_to_motor(self, tau: float) -> float:
        return self.direction * tau / (self.gear_ratio * self.torque_scale)

    def tau_from_motor(self, t: float) -> float:
        return self.direction * t * self.gear_ratio * self.torque_scale

    def kp_to_motor(self, kp: float) -> float:
        return kp / (self.gear_ratio**2 * self.torque_scale)

    def kd_to_motor(self, kd: float) -> float:
        return kd / (self.gear_ratio**2 * self.torque_scale)


class ConfigError(ValueError):
    """A motors.toml that cannot be used; the message names the file and the field."""


@dataclass(frozen=True)
class CyberGearConfig:
    joints: tuple[JointConfig, ...]
    host_id: int = DEFAULT_HOST_ID
    torque_mode: str = "operation"  # "operation" (type 1, kp=kd=0 unless asked) or "current" (run_mode 3)
    kt_nm_per_a: float = KT_NM_PER_A
    position_max_rad: float = CYBERGEAR.position_rad
    limit_torque_nm: float = CYBERGEAR.torque_nm
    handshake_timeout_s: float = 1.0
    silent_timeout_s: float = 0.05  # a motor silent this long mid-run is a lost motor
    # the motors' own CAN watchdog (firmware CAN_TIMEOUT, 0x200C): no frame for this long -> the motor
    # stops. Written and read back at start-up. Off only with can_timeout_s = 0 AND can_timeout_off = True
    # (then run `motors watchdog`, see docs/cybergear.md): a value rounding to 0 ticks is refused, not "off"
    can_timeout_s: float = 0.05
    can_timeout_off: bool = False
    rate_hz: float = 1000.0  # for the bus-load check
    bitrate: int = 1_000_000
    joint_names: tuple[str, ...] = ACTUATED_JOINTS  # the node's joint order
    extra: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        if self.torque_mode not in ("operation", "current"):
            raise ValueError(f"torque_mode must be 'operation' or 'current', got {self.torque_mode!r}")
        names = [j.name for j in self.joints]
        dup = sorted({n for n in names if names.count(n) > 1})
        if dup:
            raise ValueError(f"joint {', '.join(dup)} listed more than once")
        unknown = [n for n in names if n not in self.joint_names]
        if unknown:
            raise ValueError(f"unknown joint {', '.join(map(repr, unknown))} (the spine's joints are "
                             f"{', '.join(self.joint_names)})")
        missing = [n for n in self.joint_names if n not in names]
        if missing:
            raise ValueError(f"no entry for joint {', '.join(missing)} (every one of "
                             f"{', '.join(self.joint_names)} needs a [[joint]] with its can_id)")
        by_name = {j.name: j for j in self.joints}
        object.__setattr__(self, "joints", tuple(by_name[n] for n in self.joint_names))
        ids = [j.can_id for j in self.joints]
        if len(set(ids)) != len(ids):
            raise ValueError(f"duplicate CAN ids in {ids}")
        if not 0 <= self.host_id <= 0xFF:
            raise ValueError(f"host_id must be 0..255, got {self.host_id}")
        if self.host_id in ids:
            raise ValueError(f"host id {self.host_id} collides with a motor id")
        for f in ("kt_nm_per_a", "position_max_rad", "limit_torque_nm", "handshake_timeout_s",
                  "silent_timeout_s", "rate_hz", "bitrate"):
            v = getattr(self, f)
            if not (math.isfinite(v) and v > 0):
                raise ValueError(f"{f} must be a finite number > 0, got {v}")
        for f, (lo, hi, why) in BUS_RANGES.items():
            _check(f, getattr(self, f), lo, hi, why)
        period = 1.0 / self.rate_hz
        _check("silent_timeout_s", self.silent_timeout_s, 2 * period, SILENT_TIMEOUT_MAX_S,
               "from two control periods (2 / rate_hz) to the longest a lost motor may go unnoticed")
        self._check_can_timeout(period)
        self._check_joint_ranges()

    def _check_can_timeout(self, period: float) -> None:
        v = self.can_timeout_s
        if not (math.isfinite(v) and v >= 0):
            raise ValueError(f"can_timeout_s must be a finite number >= 0 (0: off), got {v}")
        if not isinstance(self.can_timeout_off, bool):
            raise ValueError(f"can_timeout_off must be true or false, got {self.can_timeout_off!r}")
        if v == 0:
            if not self.can_timeout_off:
                raise ValueError("can_timeout_s = 0 turns the motors' own CAN watchdog off: if that is "
                                 "meant, also set can_timeout_off = true (and run `sparc-quad motors "
                                 "watchdog`)")
            return
        if self.can_timeout_off:
            raise ValueError(f"can_timeout_off = true needs can_timeout_s = 0, got {v:g}")
        tick_s = 1.0 / CAN_TIMEOUT_TICKS_PER_S
        if self.can_timeout_ticks == 0:
            raise ValueError(f"can_timeout_s = {v:g} s rounds to 0 CAN_TIMEOUT ticks of {tick_s * 1e6:g} us, "
                             "which the firmware reads as off: give a timeout of at least two control "
                             "periods, or 0 with can_timeout_off = true")
        if v < 2 * period:
            raise ValueError(f"can_timeout_s must be >= two control periods (2 / rate_hz = {2 * period:g} s; "
                             f"shorter trips the motors between two frames), got {v:g}")
        if self.can_timeout_ticks > CAN_TIMEOUT_MAX_TICKS:
            raise ValueError(f"can_timeout_s must be <= {CAN_TIMEOUT_MAX_TICKS * tick_s:g} "
                             f"s (the firmware's CAN_TIMEOUT range), got {v}")

    def _check_joint_ranges(self) -> None:
        """Each joint's range (params.JOINT_LOWER/UPPER_RAD) must map to motor positions the frames can
        carry (+-position_max_rad): else feedback clamps and the node reads a wrong angle."""
        pmax = self.position_max_rad
        for j in self.joints:
            ends = sorted(j.q_to_motor(q) for q in (JOINT_LOWER_RAD[j.name], JOINT_UPPER_RAD[j.name]))
            if ends[0] < -pmax or ends[1] > pmax:
                raise ValueError(
                    f"{j.name}: its range [{JOINT_LOWER_RAD[j.name]:g}, {JOINT_UPPER_RAD[j.name]:g}] rad is "
                    f"motor positions [{ends[0]:.4g}, {ends[1]:.4g}] rad with gear_ratio {j.gear_ratio:g} "
                    f"and zero_offset_rad {j.zero_offset_rad:g}, outside the frames' +-{pmax:g} rad")

    @property
    def can_timeout_ticks(self) -> int:
        """The firmware's CAN_TIMEOUT value for `can_timeout_s` (see protocol.CAN_TIMEOUT_TICKS_PER_S)."""
        return round(self.can_timeout_s * CAN_TIMEOUT_TICKS_PER_S)

    @property
    def ranges(self) -> Ranges:
        return Ranges(position_max=self.position_max_rad)

    @property
    def ids(self) -> tuple[int, ...]:
        return tuple(j.can_id for j in self.joints)

    def with_(self, **kw) -> CyberGearConfig:
        return replace(self, **kw)


def _check(name: str, v: float, lo: float, hi: float, why: str) -> None:
    if not lo <= v <= hi:
        raise ValueError(f"{name} must be in [{lo:g}, {hi:g}] ({why}), got {v:g}")


SILENT_TIMEOUT_MAX_S = 10.0
# [lo, hi] of each number against physics and the CyberGear (CYBERGEAR in spine_module.params), and why
JOINT_RANGES = {
    "gear_ratio": (0.1, 100.0, "a transmission between motor and joint; below 0.1 the joint gets at most "
                   f"{0.1 * CYBERGEAR.torque_nm:g} N*m"),
    "torque_scale": (0.5, 2.0, "a calibration of the motor's torque estimate, not a different motor"),
    "zero_offset_rad": (-CYBERGEAR.position_table_rad, CYBERGEAR.position_table_rad,
                        "a motor position the frames can carry"),
}
BUS_RANGES = {
    "kt_nm_per_a": (KT_NM_PER_A / 2, 2 * KT_NM_PER_A, "the manual's torque constant within a factor of 2"),
    "position_max_rad": (CYBERGEAR.position_rad, CYBERGEAR.position_table_rad,
                         "the frames' position range: 12.5 (sample code) or 4pi (the manual's tables)"),
    "limit_torque_nm": (0.01, CYBERGEAR.torque_nm, "the CyberGear's peak torque"),
    "handshake_timeout_s": (0.01, 60.0, "the motors answer within about 250 us"),
    "rate_hz": (1.0, 10_000.0, "a control rate the node can pace"),
    "bitrate": (10_000, 1_000_000, "CAN 2.0 bitrates; the CyberGear talks at 1 Mbit/s"),
}

# key -> (kind, default); kinds: "float" (finite), "int", "str", "bool", "pos" (float or "4pi")
_BUS_KEYS = {"host_id": ("int", DEFAULT_HOST_ID), "torque_mode": ("str", "operation"),
             "kt_nm_per_a": ("float", KT_NM_PER_A), "position_max_rad": ("pos", CYBERGEAR.position_rad),
             "limit_torque_nm": ("float", CYBERGEAR.torque_nm), "handshake_timeout_s": ("float", 1.0),
             "silent_timeout_s": ("float", 0.05), "can_timeout_s": ("float", 0.05),
             "can_timeout_off": ("bool", False), "rate_hz": ("float", 1000.0), "bitrate": ("int", 1_000_000)}
_JOINT_KEYS = {"name": ("str", None), "can_id": ("int", None), "direction": ("int", 1),
               "zero_offset_rad": ("float", 0.0), "gear_ratio": ("float", 1.0),
               "torque_scale": ("float", 1.0)}


def _value(where: str, key: str, kind: str, v: object) -> object:
    if kind == "str":
        if not isinstance(v, str):
            raise ValueError(f"{where}.{key} must be a string, got {v!r}")
        return v
    if kind == "bool":
        if not isinstance(v, bool):
            raise ValueError(f"{where}.{key} must be true or false, got {v!r}")
        return v
    if kind == "int":
        if isinstance(v, bool) or not isinstance(v, int):
            raise ValueError(f"{where}.{key} must be an integer, got {v!r}")
        return v
    if kind == "pos" and isinstance(v, str):
        if v.strip().lower() in ("4pi", "4*pi"):
            return CYBERGEAR.position_table_rad
        raise ValueError(f"{where}.{key} must be a number or \"4pi\", got {v!r}")
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise ValueError(f"{where}.{key} must be a number, got {v!r}")
    if not math.isfinite(v):
        raise ValueError(f"{where}.{key} must be finite, got {v}")
    return float(v)


def _table(where: str, raw: object, keys: dict[str, tuple[str, object]]) -> dict[str, object]:
    if not isinstance(raw, dict):
        raise ValueError(f"{where} must be a table, got {type(raw).__name__}")
    unknown = [k for k in raw if k not in keys]
    if unknown:
        raise ValueError(f"{where}: unknown key {', '.join(map(repr, unknown))} (known: {', '.join(keys)})")
    out = {}
    for k, (kind, default) in keys.items():
        if k in raw:
            out[k] = _value(where, k, kind, raw[k])
        elif default is None:
            raise ValueError(f"{where}: missing {k!r}")
        else:
            out[k] = default
    return out


def parse_config(raw: dict) -> CyberGearConfig:
    """A config from the parsed TOML tables; ValueError naming the table and field."""
    unknown = [k for k in raw if k not in ("bus", "joint")]
    if unknown:
        raise ValueError(f"unknown table or key {', '.join(map(repr, unknown))} (known: [bus], [[joint]])")
    bus = _table("[bus]", raw.get("bus", {}), _BUS_KEYS)
    joints_raw = raw.get("joint", [])
    if isinstance(joints_raw, dict):
        raise ValueError("[joint] is a single table: write each joint as [[joint]] (an array of tables)")
    if not isinstance(joints_raw, list) or not joints_raw:
        raise ValueError("no [[joint]] entries")
    joints = []
    for i, j in enumerate(joints_raw):
        name = j.get("name") if isinstance(j, dict) else None
        where = f"[[joint]] #{i + 1}" + (f" ({name})" if isinstance(name, str) else "")
        vals = _table(where, j, _JOINT_KEYS)
        try:
            joints.append(JointConfig(**vals))
        except ValueError as e:
            raise ValueError(f"{where}: {e}") from None
    return CyberGearConfig(joints=tuple(joints), **bus)


def load_config(path: str | Path | None = None) -> CyberGearConfig:
    """Read and check the TOML file (default: the packaged `motors.toml`). Raises ConfigError naming the
    file and the field for a missing/unreadable file, bad TOML, unknown keys, or bad values."""
    path = Path(path) if path is not None else DEFAULT_CONFIG_PATH
    try:
        with open(path, "rb") as f:
            raw = tomllib.load(f)
    except OSError as e:
        raise ConfigError(f"{path}: cannot read the motor config: {e.strerror or e}") from None
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as e:
        raise ConfigError(f"{path}: not valid TOML: {e}") from None
    try:
        return parse_config(raw)
    except ValueError as e:
        raise ConfigError(f"{path}: {e}") from None
