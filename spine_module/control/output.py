"""What every task-space controller returns, and the small state they share (gains, target)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from spine_module import params as P
from spine_module.control import kernel as kn
from spine_module.model import N_ACT, SpineData, SpineModel

BACKENDS = ("auto", "numba", "pinocchio")


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


def load_compiled_step(backend: str) -> object | None:
    """The compiled whole-step kernel for backend "numba"/"auto", None for "pinocchio" (or "auto" without
    numba). "numba" without a working numba is an error naming the cause."""
    if backend not in BACKENDS:
        raise ValueError(f"backend must be one of {BACKENDS}, got {backend!r}")
    if backend == "pinocchio":
        return None
    try:
        from spine_module.control.compiled import spine_step
    except Exception as exc:  # ImportError, or numba failing to compile/load on this platform
        if backend == "numba":
            raise RuntimeError(f"backend='numba' needs a working numba: {exc}") from exc
        return None
    return spine_step


def _vec3(value: object, name: str) -> list[float]:
    """Three finite floats (set every 1 kHz tick by the node: plain floats, no numpy temporaries)."""
    try:
        if isinstance(value, np.ndarray) and value.dtype == np.float64:
            vals = value.reshape(-1).tolist()
        elif type(value) is list:
            vals = [float(v) for v in value]
        else:
            vals = np.asarray(value, dtype=float).reshape(-1).tolist()
    except (TypeError, ValueError):
        vals = None
    if vals is None or len(vals) != 3 or not (math.isfinite(vals[0]) and math.isfinite(vals[1])
                                               and math.isfinite(vals[2])):
        raise ValueError(f"{name} must be 3 finite numbers, got {value!r}")
    return vals


class TaskController:
    """Shared state of the task-space laws: diagonal K and D, the target, the workspace, the clamp.

    backend: "pinocchio" runs the reference path (pinocchio kinematics and RNEA, numpy algebra);
    "numba" the compiled whole-step kernel generated from the same `pin.Model` (kernel.py); "auto" (the
    default) the kernel where numba works, else pinocchio. Gains, target and limits live in one packed
    array that both paths read (K, D, x_d, dx_d, ddx_d are views into it).
    """

    _KERNEL_MODE = kn.MODE_PD

    def __init__(self, model: SpineModel, k: object = P.K_DEFAULT, d: object = P.D_DEFAULT,
                 backend: str = "auto") -> None:
        self.model = model
        self.data: SpineData = model.create_data()
        self._compiled = load_compiled_step(backend)
        self.backend = "numba" if self._compiled is not None else "pinocchio"
        self._prm = kn.pack_model(model)
        oc = int(self._prm[kn.H_CTRL])
        self._ctrl = self._prm[oc:]
        self._ctrl[kn.C_MODE] = self._KERNEL_MODE
        self.K = self._ctrl[kn.C_K:kn.C_K + 3]
        self.D = self._ctrl[kn.C_D:kn.C_D + 3]
        self.x_d = self._ctrl[kn.C_X_D:kn.C_X_D + 3]
        self.x_d[:] = P.X_EQUILIBRIUM
        self.dx_d = self._ctrl[kn.C_DX_D:kn.C_DX_D + 3]
        self.ddx_d = self._ctrl[kn.C_DDX_D:kn.C_DDX_D + 3]
        self._res = np.zeros(kn.result_size(N_ACT))
        r = self._res
        self.out = ControlOutput(tau=r[0:N_ACT], tau_raw=r[N_ACT:2 * N_ACT], x=r[2 * N_ACT:2 * N_ACT + 3],
                                 dx=r[2 * N_ACT + 3:2 * N_ACT + 6])
        self._err = np.zeros(3)
        self._derr = np.zeros(3)
        self._f = np.zeros(3)
        self._tau_full = np.zeros(model.nq)
        self._tau_max = self._ctrl[kn.C_TAU_MAX:kn.C_TAU_MAX + N_ACT]
        self._tau_max[:] = model.torque_limit_nm
        self._tau_min = -self._tau_max
        self._zero_accel = np.zeros(3)  # the fixed-origin law's base acceleration (read only)
        self.set_gains(k, d)

    def set_gains(self, k: object | None = None, d: object | None = None) -> None:
        """K = diag(k_x N/m, k_z N/m, k_theta N*m/rad), D = diag(d_x N*s/m, d_z N*s/m, d_theta N*m*s/rad)."""
        if k is not None:
            k = _vec3(k, "K")
            if min(k) < 0:
                raise ValueError(f"K must be non-negative, got {k}")
            self.K[:] = k
        if d is not None:
            d = _vec3(d, "D")
            if min(d) < 0:
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

    def step(self, q: np.ndarray, dq: np.ndarray, ddq1: float = 0.0,
             base_accel: np.ndarray | None = None) -> ControlOutput:
        """One cycle: joint state (rad, rad/s, [q1..q4]), torso acceleration q̈1 (rad/s²) and the base
        joint origin's linear acceleration in the hind-body frame (m/s², gravity not included; None: 0,
        the paper's fixed-origin law) → torques. The compiled step takes q, dq and `base_accel` as writable
        C-contiguous float64 arrays without a copy; anything else (a read-only array, a list, float32)
        goes through numba's failed dispatch to the reference path, ~100x the cost.

        Never raises: a bad input gives tau = 0, ok False and `error` naming it.
        """
        fn = self._compiled
        if fn is None:
            return self.step_reference(q, dq, ddq1, base_accel)
        try:
            status = fn(self._prm, q, dq, ddq1, self._zero_accel if base_accel is None else base_accel,
                        self._res, self.out.saturated)
        except Exception:  # not C-contiguous float64 vectors: the reference path converts or names it
            return self.step_reference(q, dq, ddq1, base_accel)
        if status != kn.OK:
            return self._fail(self.check_state(q, dq, ddq1, base_accel)
                              or "controller produced a non-finite torque")
        out = self.out
        out.ok = True
        out.error = None
        return out

    def step_reference(self, q: np.ndarray, dq: np.ndarray, ddq1: float = 0.0,
                       base_accel: np.ndarray | None = None) -> ControlOutput:
        raise NotImplementedError

    def kernel_arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
        """(prm, res, saturated) the compiled step `kernel.spine_step` reads and fills for this controller
        (compiled code that calls the kernel itself passes these), None on the pinocchio backend."""
        if self._compiled is None:
            return None
        return self._prm, self._res, self.out.saturated

    def _fail(self, reason: str) -> ControlOutput:
        out = self.out
        out.tau[:] = 0.0
        out.tau_raw[:] = 0.0
        out.saturated[:] = False
        out.ok = False
        out.error = reason
        return out

    def _finish(self, tau_full: np.ndarray, q: np.ndarray, dq: np.ndarray, ddq1: float,
                base_accel: np.ndarray | None = None) -> ControlOutput:
        out, data = self.out, self.data
        out.tau_raw[:] = tau_full[1:]
        # NaN/inf in any input propagates into the torque or the pose: one cheap check on the way out
        if not (math.isfinite(out.tau_raw.sum()) and math.isfinite(data.x.sum())):
            return self._fail(self.check_state(q, dq, ddq1, base_accel)
                              or "controller produced a non-finite torque")
        np.clip(out.tau_raw, self._tau_min, self._tau_max, out=out.tau)
        np.not_equal(out.tau, out.tau_raw, out=out.saturated)
        out.x[:] = data.x
        out.dx[:] = data.dx
        out.ok = True
        out.error = None
        return out

    @staticmethod
    def check_state(q: np.ndarray, dq: np.ndarray, ddq1: float, base_accel: object = None) -> str | None:
        """Name the first bad input, or None when q (4,), dq (4,), ddq1 and base_accel (3,) (None: 0)
        are finite."""
        q, dq = np.asarray(q), np.asarray(dq)
        if q.shape != (4,) or dq.shape != (4,):
            return f"state must be 4 joints, got q{q.shape} dq{dq.shape}"
        if not np.all(np.isfinite(q)):
            return "q is not finite"
        if not np.all(np.isfinite(dq)):
            return "dq is not finite"
        if not np.isfinite(ddq1):
            return "ddq1 is not finite"
        if base_accel is not None:
            a = np.asarray(base_accel)
            if a.shape != (3,):
                return f"base_accel must be 3 values, got {a.shape}"
            if not np.all(np.isfinite(a)):
                return "base_accel is not finite"
        return None
