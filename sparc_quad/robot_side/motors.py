"""The robot's motors, once: the newest command through `MotorCommand.torque` with the command timeout and
the watchdog's latch, and the feedback as a CyberGear frame carries it (quantised, clipped to its ranges)."""

from __future__ import annotations

import numpy as np

from spine_module import params as P
from spine_module.buses.cybergear.protocol import DEFAULT_RANGES, Ranges
from spine_module.messages.motor import MotorCommand, MotorFeedback


def _quantise(x: np.ndarray, lsb: float) -> None:
    np.multiply(np.round(x / lsb), lsb, out=x)


def as_frame(fb: MotorFeedback, quantise: bool = True, ranges: Ranges = DEFAULT_RANGES) -> MotorFeedback:
    """Quantise `fb` in place to the sensors' LSBs (P.SENSORS: idempotent when the plant already did) and
    clip it to what a type-2 frame can carry (`ranges`, the CAN protocol's)."""
    fb.q, fb.dq, fb.tau = (np.array(a, dtype=float) for a in (fb.q, fb.dq, fb.tau))
    if quantise:
        s = P.SENSORS
        _quantise(fb.q, s.position_lsb_rad)
        _quantise(fb.dq, s.velocity_lsb_rad_s)
        _quantise(fb.tau, s.torque_lsb_nm)
    np.clip(fb.q, -ranges.position_max, ranges.position_max, out=fb.q)
    np.clip(fb.dq, -ranges.velocity_max, ranges.velocity_max, out=fb.dq)
    np.clip(fb.tau, -ranges.torque_max, ranges.torque_max, out=fb.tau)
    return fb


class MotorModel:
    """Motors that hold the newest command: zero torque when it is disabled, older than
    `command_timeout_s` on the robot's clock, or while the robot's fault is latched; clipped to
    `torque_limit_nm`."""

    def __init__(self, n: int = 3, command_timeout_s: float = P.MOTOR_COMMAND_TIMEOUT_S,
                 torque_limit_nm: float = DEFAULT_RANGES.torque_max) -> None:
        self.command_timeout_s = command_timeout_s
        self.torque_limit_nm = torque_limit_nm
        self.command: MotorCommand | None = None
        self._command_clock_s: float | None = None
        self.tau = np.zeros(n)

    def accept(self, command: MotorCommand | None, clock_s: float) -> None:
        """A command arrived at `clock_s` (None: nothing new; the motor keeps the last one)."""
        if command is not None:
            self.command, self._command_clock_s = command, clock_s

    def torque(self, q: np.ndarray, dq: np.ndarray, clock_s: float, latched: bool) -> np.ndarray:
        """Output torque (N*m) at the motors' own q (rad), dq (rad/s); a view reused every call."""
        c = self.command
        stale = self._command_clock_s is None or clock_s - self._command_clock_s > self.command_timeout_s
        if c is None or not c.enable or latched or stale:
            self.tau[:] = 0.0
        else:
            self.tau[:] = c.torque(q, dq)
            np.clip(self.tau, -self.torque_limit_nm, self.torque_limit_nm, out=self.tau)
        return self.tau
