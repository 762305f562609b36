"""Per-joint configuration of the CyberGear backend, read from one TOML file a user edits.

Joint-side quantities (what the node sees) relate to the motor's output-shaft quantities (what the frames
carry; the CyberGear's 7.75:1 gearbox is inside the motor, its frames are already output-side) by

    q_joint   = direction * (q_motor - zero_offset_rad) / gear_ratio
    dq_joint  = direction * dq_motor / gear_ratio
    tau_joint = direction * tau_motor * gear_ratio * torque_scale

`gear_ratio` is any transmission between the motor's output shaft and the joint (1 on the SPARC spine);
`torque_scale` corrects the motor's torque estimate if a bench calibration says so (1 by default).
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, field, replace
from pathlib import Path

from spine_module.buses.cybergear.protocol import DEFAULT_HOST_ID, Ranges

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
        if self.direction not in (1, -1):
            raise ValueError(f"{self.name}: direction must be +1 or -1, got {self.direction}")
        if not 1 <= self.can_id <= 0x7F:
            raise ValueError(f"{self.name}: can_id must be 1..127, got {self.can_id}")
        if not (self.gear_ratio > 0 and self.torque_scale > 0):
            raise ValueError(f"{self.name}: gear_ratio and torque_scale must be > 0")

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


@dataclass(frozen=True)
class CyberGearConfig:
    joints: tuple[JointConfig, ...]
    host_id: int = DEFAULT_HOST_ID
    torque_mode: str = "operation"  # "operation" (type 1, kp=kd=0 unless asked) or "current" (run_mode 3)
    kt_nm_per_a: float = KT_NM_PER_A
    position_max_rad: float = 12.5
    limit_torque_nm: float = 12.0
    handshake_timeout_s: float = 1.0
    silent_timeout_s: float = 0.05  # a motor silent this long mid-run is a lost motor
    rate_hz: float = 1000.0  # for the bus-load check
    bitrate: int = 1_000_000
    extra: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        if self.torque_mode not in ("operation", "current"):
            raise ValueError(f"torque_mode must be 'operation' or 'current', got {self.torque_mode!r}")
        ids = [j.can_id for j in self.joints]
        if len(set(ids)) != len(ids):
            raise ValueError(f"duplicate CAN ids in {ids}")
        if self.host_id in ids:
            raise ValueError(f"host id {self.host_id} collides with a motor id")

    @property
    def ranges(self) -> Ranges:
        return Ranges(position_max=self.position_max_rad)

    @property
    def ids(self) -> tuple[int, ...]:
        return tuple(j.can_id for j in self.joints)

    def with_(self, **kw) -> CyberGearConfig:
        return replace(self, **kw)


def _pos_max(value: float | str) -> float:
    if isinstance(value, str):
        if value.strip().lower() in ("4pi", "4*pi"):
            return 4 * math.pi
        return float(value)
    return float(value)


def load_config(path: str | Path | None = None) -> CyberGearConfig:
    """Read the TOML file (default: the packaged `motors.toml`)."""
    path = Path(path) if path is not None else DEFAULT_CONFIG_PATH
    with open(path, "rb") as f:
        raw = tomllib.load(f)
    bus = raw.get("bus", {})
    joints = tuple(JointConfig(name=j["name"], can_id=int(j["can_id"]), direction=int(j.get("direction", 1)),
                               zero_offset_rad=float(j.get("zero_offset_rad", 0.0)),
                               gear_ratio=float(j.get("gear_ratio", 1.0)),
                               torque_scale=float(j.get("torque_scale", 1.0)))
                   for j in raw.get("joint", []))
    if not joints:
        raise ValueError(f"{path}: no [[joint]] entries")
    return CyberGearConfig(
        joints=joints, host_id=int(bus.get("host_id", DEFAULT_HOST_ID)),
        torque_mode=str(bus.get("torque_mode", "operation")),
        kt_nm_per_a=float(bus.get("kt_nm_per_a", KT_NM_PER_A)),
        position_max_rad=_pos_max(bus.get("position_max_rad", 12.5)),
        limit_torque_nm=float(bus.get("limit_torque_nm", 12.0)),
        handshake_timeout_s=float(bus.get("handshake_timeout_s", 1.0)),
        silent_timeout_s=float(bus.get("silent_timeout_s", 0.05)),
        rate_hz=float(bus.get("rate_hz", 1000.0)), bitrate=int(bus.get("bitrate", 1_000_000)))
