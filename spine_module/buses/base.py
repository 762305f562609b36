"""The one interface between the spine node and its motors, in the style of python-can's `BusABC`.

A backend moves `MotorCommand`s out and `MotorFeedback` in; everything above it (controller, safety,
node) is the same object whatever the transport: in-process coupling to a simulator, LCM to a simulated
robot, or CyberGear frames on a CAN bus.

All quantities are on the joint (output) side of the gearbox, in the joint's sign convention.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass, field, fields, replace

import numpy as np


class MotorBusError(RuntimeError):
    """A transport failure the node must turn into its safe state (bus-off, send error, lost motor)."""


def _zeros(n: int) -> np.ndarray:
    return np.zeros(n)


class _Copyable:
    """A copy that shares no array with the original: what a transport would hand over, at a fraction
    of `copy.deepcopy`'s cost (the in-process bus copies twice per 1 kHz tick)."""

    def copy(self):
        return replace(self, **{f.name: v.copy() for f in fields(self)
                                if isinstance(v := getattr(self, f.name), np.ndarray)})


@dataclass
class MotorCommand(_Copyable):
    """Operation-control command per joint: tau = tau_ff + kp (q_des - q) + kd (dq_des - dq).

    Units: tau_ff N*m, q_des rad, dq_des rad/s, kp N*m/rad, kd N*m*s/rad. `enable=False` asks the backend
    to put the motors in their stopped (zero-torque) state.
    """

    tau_ff: np.ndarray
    q_des: np.ndarray = field(default_factory=lambda: _zeros(3))
    dq_des: np.ndarray = field(default_factory=lambda: _zeros(3))
    kp: np.ndarray = field(default_factory=lambda: _zeros(3))
    kd: np.ndarray = field(default_factory=lambda: _zeros(3))
    enable: bool = True
    stamp_s: float = 0.0
    seq: int = 0

    @classmethod
    def zero(cls, n: int = 3, enable: bool = False) -> MotorCommand:
        return cls(tau_ff=_zeros(n), q_des=_zeros(n), dq_des=_zeros(n), kp=_zeros(n), kd=_zeros(n),
                   enable=enable)


@dataclass
class MotorFeedback(_Copyable):
    """Measured joint state per motor. `stamp_s` is when it was measured, on the producer's clock (s)."""

    q: np.ndarray  # rad
    dq: np.ndarray  # rad/s
    tau: np.ndarray  # estimated torque, N*m
    temperature_c: np.ndarray = field(default_factory=lambda: _zeros(3))  # deg C
    mode: np.ndarray = field(default_factory=lambda: np.zeros(3, dtype=np.int32))  # 0 reset, 1 cal, 2 run
    fault: np.ndarray = field(default_factory=lambda: np.zeros(3, dtype=np.int32))  # per-motor fault bits
    # Module load cells (hind, front spine link), N; NaN when the backend has none (e.g. motors-only CAN).
    load_cell_n: np.ndarray = field(default_factory=lambda: np.full(2, np.nan))
    stamp_s: float = 0.0
    seq: int = 0


class MotorBus(ABC):
    """Send commands to and receive feedback from the spine's motors.

    `receive(timeout_s)` returns the newest feedback not yet returned, or None when none arrived within
    the timeout; a lockstep node blocks on it, a real-time node polls with timeout 0. `send` never blocks
    the control loop. Backends raise `MotorBusError` for transport faults.
    """

    joint_names: tuple[str, ...] = ("q2", "q3", "q4")

    def start(self, timeout_s: float = 1.0) -> None:  # noqa: B027 - optional hook
        """Handshake with the motors; raise MotorBusError naming any that did not answer."""

    @abstractmethod
    def send(self, command: MotorCommand) -> None: ...

    @abstractmethod
    def receive(self, timeout_s: float | None = 0.0) -> MotorFeedback | None: ...

    def stop(self) -> None:
        """Command zero torque / stopped motors. Must be safe to call more than once."""
        self.send(MotorCommand.zero(len(self.joint_names), enable=False))

    def shutdown(self) -> None:  # noqa: B027 - optional hook
        """Release the transport."""

    def __enter__(self) -> MotorBus:
        return self

    def __exit__(self, *exc: object) -> None:
        try:
            self.stop()
        finally:
            self.shutdown()
