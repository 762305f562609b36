"""Bus-load model of a CAN 2.0B bus carrying CyberGear traffic.

An extended data frame with n data bytes has 1 SOF + 11 base id + SRR + IDE + 18 id extension + RTR +
r1 + r0 + 4 DLC + 8n data + 15 CRC bits in the stuffed part (54 + 8n bits), then 1 CRC delimiter + 2 ACK
+ 7 EOF bits and 3 bits of intermission (13 bits). Stuffing inserts at most one bit per four after the
first of the stuffed part: floor((54 + 8n - 1) / 4). For n = 8: 131 bits unstuffed, 160 worst case.

Each control cycle costs one command frame and one feedback frame per motor (operation control: type 1
-> type 2; current mode: type 18 iq_ref write -> type 2).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

log = logging.getLogger(__name__)

WARN_UTILISATION = 0.80


def frame_bits(dlc: int = 8, extended: bool = True, worst_case_stuffing: bool = True) -> int:
    """Bits on the wire of one data frame, including the 3-bit intermission."""
    if not 0 <= dlc <= 8:
        raise ValueError("dlc must be 0..8")
    stuffed = (54 if extended else 34) + 8 * dlc
    stuff = (stuffed - 1) // 4 if worst_case_stuffing else 0
    return stuffed + stuff + 13


@dataclass(frozen=True)
class BusLoad:
    motors: int
    rate_hz: float
    bitrate: int
    frames_per_s: float
    bits_per_s_nominal: float
    bits_per_s_worst: float

    @property
    def utilisation_nominal(self) -> float:
        return self.bits_per_s_nominal / self.bitrate

    @property
    def utilisation_worst(self) -> float:
        return self.bits_per_s_worst / self.bitrate

    @property
    def over_warning(self) -> bool:
        return self.utilisation_worst > WARN_UTILISATION

    def as_dict(self) -> dict[str, float | int | bool]:
        return {"motors": self.motors, "rate_hz": self.rate_hz, "bitrate": self.bitrate,
                "frames_per_s": self.frames_per_s, "bits_per_s_nominal": self.bits_per_s_nominal,
                "bits_per_s_worst": self.bits_per_s_worst, "utilisation_nominal": self.utilisation_nominal,
                "utilisation_worst": self.utilisation_worst, "over_warning": self.over_warning,
                "max_rate_hz_at_80pct_worst": max_loop_rate_hz(self.motors, self.bitrate),
                "max_rate_hz_at_100pct_worst": max_loop_rate_hz(self.motors, self.bitrate, 1.0)}


def bus_load(motors: int, rate_hz: float, bitrate: int = 1_000_000, frames_per_motor_per_cycle: int = 2,
             warn: bool = True) -> BusLoad:
    """Load of `motors` motors each exchanging `frames_per_motor_per_cycle` 8-byte frames at rate_hz."""
    fps = motors * frames_per_motor_per_cycle * rate_hz
    load = BusLoad(motors, rate_hz, bitrate, fps, fps * frame_bits(8, True, False),
                   fps * frame_bits(8, True, True))
    if warn and load.over_warning:
        log.warning("CAN bus load %.0f %% (worst-case stuffing) of %d bit/s for %d motors at %.0f Hz exceeds "
                    "%.0f %%; the highest rate under that is %.0f Hz", 100 * load.utilisation_worst, bitrate,
                    motors, rate_hz, 100 * WARN_UTILISATION, max_loop_rate_hz(motors, bitrate))
    return load


def max_loop_rate_hz(motors: int, bitrate: int = 1_000_000, utilisation: float = WARN_UTILISATION,
                     frames_per_motor_per_cycle: int = 2) -> float:
    """Highest control rate keeping worst-case utilisation at or below `utilisation`."""
    return utilisation * bitrate / (motors * frames_per_motor_per_cycle * frame_bits(8, True, True))
