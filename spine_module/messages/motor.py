"""Motor command and feedback: what crosses between the spine node and its motors, whatever the bus.

They live with the messages (not the buses) so that the codec, the buses, the robot side and the
simulators share them without an arrow pointing back up. All quantities are on the joint (output) side of
the gearbox, in the joint's sign convention.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


def _zeros(n: int) -> np.ndarray:
    return np.zeros(n)


def _c(v):
    """An array's (or list's) own copy; anything else (a tuple, a number) as it is."""
    return v.copy() if isinstance(v, (np.ndarray, list)) else v


@dataclass
class MotorCommand:
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

    def torque(self, q: np.ndarray | float, dq: np.ndarray | float) -> np.ndarray:
        """The motor law, the one implementation of it: output torque (N*m) at measured q (rad),
        dq (rad/s). Clipping to a torque limit and disabled/timed-out handling are the caller's."""
        return self.tau_ff + self.kp * (self.q_des - q) + self.kd * (self.dq_des - dq)

    def copy(self) -> MotorCommand:
        """A copy sharing no array with this one: what a transport hands over (the in-process bus copies
        every command; one constructor call, not `copy.deepcopy`)."""
        try:  # numpy arrays (what every producer sends)
            return MotorCommand(self.tau_ff.copy(), self.q_des.copy(), self.dq_des.copy(), self.kp.copy(),
                                self.kd.copy(), self.enable, self.stamp_s, self.seq)
        except AttributeError:  # a tuple somewhere
            return MotorCommand(_c(self.tau_ff), _c(self.q_des), _c(self.dq_des), _c(self.kp), _c(self.kd),
                                self.enable, self.stamp_s, self.seq)

    @classmethod
    def zero(cls, n: int = 3, enable: bool = False) -> MotorCommand:
        return cls(tau_ff=_zeros(n), q_des=_zeros(n), dq_des=_zeros(n), kp=_zeros(n), kd=_zeros(n),
                   enable=enable)


@dataclass
class MotorFeedback:
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

    def copy(self) -> MotorFeedback:
        """A copy sharing no array with this one (see `MotorCommand.copy`)."""
        try:
            return MotorFeedback(self.q.copy(), self.dq.copy(), self.tau.copy(), self.temperature_c.copy(),
                                 self.mode.copy(), self.fault.copy(), self.load_cell_n.copy(), self.stamp_s,
                                 self.seq)
        except AttributeError:
            return MotorFeedback(_c(self.q), _c(self.dq), _c(self.tau), _c(self.temperature_c), _c(self.mode),
                                 _c(self.fault), _c(self.load_cell_n), self.stamp_s, self.seq)
