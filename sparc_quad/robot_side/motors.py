"""The robot's motors, once: the newest command through `MotorCommand.torque` with the command timeout and
the watchdog's latch, and the feedback as a CyberGear frame carries it (quantised, clipped to its ranges)."""

from __future__ import annotations

import functools

import numpy as np

from spine_module import params as P
from spine_module.buses.cybergear.protocol import DEFAULT_RANGES, Ranges
from spine_module.messages.motor import MotorCommand, MotorFeedback


@functools.lru_cache(maxsize=8)
def _frame_limits(lsb: tuple[float, float, float], ranges: Ranges) -> tuple[np.ndarray, ...]:
    """Per-row LSB, lower and upper range of the (q, dq, tau) block, as columns (read-only)."""
    step = np.array(lsb, dtype=float).reshape(3, 1)
    top = np.array([ranges.position_max, ranges.velocity_max, ranges.torque_max], dtype=float).reshape(3, 1)
    bottom = -top
    step.flags.writeable = top.flags.writeable = bottom.flags.writeable = False
    return step, bottom, top


def as_frame(fb: MotorFeedback, quantise: bool = True, ranges: Ranges = DEFAULT_RANGES) -> MotorFeedback:
    """Quantise `fb` in place to the sensors' LSBs (P.SENSORS: idempotent when the plant already did) and
    clip it to what a type-2 frame can carry (`ranges`, the CAN protocol's). One (3, 3) block for q, dq
    and tau (the same element-wise arithmetic as per vector; `fb.q`/`dq`/`tau` become its rows)."""
    s = P.SENSORS
    step, bottom, top = _frame_limits((s.position_lsb_rad, s.velocity_lsb_rad_s, s.torque_lsb_nm), ranges)
    a = np.array((fb.q, fb.dq, fb.tau), dtype=float)
    if a.shape != (3, 3):
        raise ValueError(f"motor feedback q, dq, tau must be 3 values each, got shape {a.shape}")
    if quantise:
        np.multiply(np.rint(a / step), step, out=a)
    np.minimum(np.maximum(a, bottom, out=a), top, out=a)  # = np.clip, without its Python wrapper
    fb.q, fb.dq, fb.tau = a[0], a[1], a[2]
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
            np.minimum(np.maximum(c.torque(q, dq), -self.torque_limit_nm), self.torque_limit_nm,
                       out=self.tau)  # = np.clip, without its Python wrapper
        return self.tau
