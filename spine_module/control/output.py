"""What every task-space controller returns, and the small state they share (gains, target)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from spine_module import params as P
from spine_module.model import N_ACT, SpineData, SpineModel


@dataclass
class ControlOutput:
    """Result of one control step; the controller reuses this object every cycle (copy to keep).

    tau: actuated joint torques (q2, q3, q4) after clamping, N*m. saturated: per-joint clamp flag.
    x, dx: task pose (m, m, rad) and velocity (m/s, m/s, rad/s). ok is False (tau = 0) when the input or
    the result was not finite; `error` then names what was wrong.
    """

    tau: np.ndarray = field(default_factory=lambda: np.zeros(N_ACT))
    tau_raw: np.ndarray = field(default_factory=lambda: np.zeros(N_ACT))
    saturated: np.ndarray = field(default_factory=lambda: np.zeros(N_ACT, dtype=bool))
    x: np.ndarray = field(default_factory=lambda: np.zeros(3))
    dx: np.ndarray = field(default_factory=lambda: np.zeros(3))
    ok: bool = True
    error: str | None = None


def _vec3(value: object, name: str) -> np.ndarray:
    arr = np.asarray(value, dtype=float).reshape(-1)
    if arr.shape != (3,) or not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must be 3 finite numbers, got {value!r}")
    return arr


class TaskController:
    """Shared state of the task-space laws: diagonal K and D, the target, the workspace, the clamp."""

    def __init__(self, model: SpineModel, k: object = P.K_DEFAULT, d: object = P.D_DEFAULT) -> None:
        self.model = model
        self.data: SpineData = model.create_data()
        self.K = np.zeros(3)
        self.D = np.zeros(3)
        self.x_d = P.X_EQUILIBRIUM.copy()
        self.dx_d = np.zeros(3)
        self.ddx_d = np.zeros(3)
        self.out = ControlOutput()
        self._err = np.zeros(3)
        self._derr = np.zeros(3)
        self._f = np.zeros(3)
        self._tau_full = np.zeros(model.nq)
        self._tau_max = model.torque_limit_nm.copy()
        self._tau_min = -self._tau_max
        self.set_gains(k, d)

    def set_gains(self, k: object | None = None, d: object | None = None) -> None:
        """K = diag(k_x N/m, k_z N/m, k_theta N*m/rad), D = diag(d_x N*s/m, d_z N*s/m, d_theta N*m*s/rad)."""
        if k is not None:
            k = _vec3(k, "K")
            if np.any(k < 0):
                raise ValueError(f"K must be non-negative, got {k}")
            self.K[:] = k
        if d is not None:
            d = _vec3(d, "D")
            if np.any(d < 0):
                raise ValueError(f"D must be non-negative, got {d}")
            self.D[:] = d

    def set_target(self, x_d: object | None = None, dx_d: object | None = None,
                   ddx_d: object | None = None) -> None:
        """Desired task pose (m, m, rad), velocity and acceleration."""
        if x_d is not None:
            self.x_d[:] = _vec3(x_d, "x_d")
        if dx_d is not None:
            self.dx_d[:] = _vec3(dx_d, "dx_d")
        if ddx_d is not None:
            self.ddx_d[:] = _vec3(ddx_d, "ddx_d")

    def _spring_damper(self) -> np.ndarray:
        """F = K (x_d - x) + D (dx_d - dx), the theta error wrapped to (-pi, pi]."""
        data = self.data
        np.subtract(self.x_d, data.x, out=self._err)
        self._err[2] = (self._err[2] + np.pi) % (2 * np.pi) - np.pi
        np.subtract(self.dx_d, data.dx, out=self._derr)
        np.multiply(self.K, self._err, out=self._f)
        self._derr *= self.D
        self._f += self._derr
        return self._f

    def _fail(self, reason: str) -> ControlOutput:
        out = self.out
        out.tau[:] = 0.0
        out.tau_raw[:] = 0.0
        out.saturated[:] = False
        out.ok = False
        out.error = reason
        return out

    def _finish(self, tau_full: np.ndarray, q: np.ndarray, dq: np.ndarray, ddq1: float) -> ControlOutput:
        out, data = self.out, self.data
        out.tau_raw[:] = tau_full[1:]
        # NaN/inf in any input propagates into the torque or the pose: one cheap check on the way out
        if not (math.isfinite(out.tau_raw.sum()) and math.isfinite(data.x.sum())):
            return self._fail(self.check_state(q, dq, ddq1) or "controller produced a non-finite torque")
        np.clip(out.tau_raw, self._tau_min, self._tau_max, out=out.tau)
        np.not_equal(out.tau, out.tau_raw, out=out.saturated)
        out.x[:] = data.x
        out.dx[:] = data.dx
        out.ok = True
        out.error = None
        return out

    @staticmethod
    def check_state(q: np.ndarray, dq: np.ndarray, ddq1: float) -> str | None:
        """Name the first bad input, or None when q (4,), dq (4,) and ddq1 are finite."""
        q, dq = np.asarray(q), np.asarray(dq)
        if q.shape != (4,) or dq.shape != (4,):
            return f"state must be 4 joints, got q{q.shape} dq{dq.shape}"
        if not np.all(np.isfinite(q)):
            return "q is not finite"
        if not np.all(np.isfinite(dq)):
            return "dq is not finite"
        if not np.isfinite(ddq1):
            return "ddq1 is not finite"
        return None
