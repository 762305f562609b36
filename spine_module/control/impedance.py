"""Computed-acceleration task impedance, eq. (3), with optional Stribeck compensation, eq. (4).

tau = M J†(ẍ_d − J̇q̇) + Jᵀ(D(ẋ_d − ẋ) + K(x_d − x)) + C q̇ + g (+ tau_friction)

M J† a + C q̇ + g is evaluated as one RNEA pass at the desired joint acceleration
ddq* = [q̈1, J†(ẍ_d − J̇q̇)]: mathematically the same as forming M and C, without building them. The
measured torso acceleration q̈1 enters ddq*, so torso pitching is compensated on a robot (0 on the bench);
the base joint origin's linear acceleration a (hind-body frame, from the torso estimate; 0 in the paper's
law, whose base joint has a fixed origin) enters as gravity g - a.
J† = Jᵀ(JJᵀ + λ²I)⁻¹ is the damped least-squares pseudo-inverse; its 3x3 solve is `solve3` (no scipy on the
robot: numpy.linalg.solve would cost about 5x LAPACK's gesv on a 3x3 through its call overhead).
"""

from __future__ import annotations

import numpy as np

from spine_module import params as P
from spine_module.control import kernel as kn
from spine_module.control.friction import StribeckFriction
from spine_module.control.linalg import solve3
from spine_module.control.output import ControlOutput, TaskController
from spine_module.model import SpineModel


class ImpedanceController(TaskController):
    _KERNEL_MODE = kn.MODE_IMPEDANCE

    def __init__(self, model: SpineModel, friction: StribeckFriction | None = None,
                 k: object = P.K_DEFAULT, d: object = P.D_DEFAULT, dls_lambda: float = P.DLS_LAMBDA,
                 backend: str = "auto") -> None:
        super().__init__(model, k, d, backend=backend)
        self.friction = friction
        if friction is not None:
            rows = friction.coefficient_rows().reshape(-1)
            self._ctrl[kn.C_FRICTION + 3:kn.C_FRICTION + 3 + rows.size] = rows
        self.friction_enabled = friction is not None  # run-time switch; needs a friction model to act
        self.lambda2 = dls_lambda**2
        self._ctrl[kn.C_LAMBDA2] = self.lambda2
        self._ddq = np.zeros(model.nv)
        self._ddq_act = self._ddq[1:]
        self._a = np.zeros(3)
        self._y = np.zeros(3)
        self._jjt = np.zeros((3, 3))
        self._lambda2_eye = self.lambda2 * np.eye(3)

    @property
    def friction_enabled(self) -> bool:
        """Eq. (4) compensation on/off at run time; acts only with a friction model."""
        return self._friction_enabled

    @friction_enabled.setter
    def friction_enabled(self, value: bool) -> None:
        self._friction_enabled = bool(value)
        self._ctrl[kn.C_FRICTION_ON] = 1.0 if (value and self.friction is not None) else 0.0

    def step_reference(self, q: np.ndarray, dq: np.ndarray, ddq1: float = 0.0,
                       base_accel: np.ndarray | None = None) -> ControlOutput:
        """The pinocchio path: the reference the compiled kernel is checked against, and its fallback.
        A non-zero `base_accel` (hind-body frame, m/s^2) runs the RNEA with gravity g - a (`SpineModel.rnea`);
        None or zeros the fixed-origin RNEA, unchanged."""
        try:
            model, data = self.model, self.data
            model.update_kinematics(data, q, dq)
            J = data.J_act
            # desired task acceleration minus drift, mapped through the DLS pseudo-inverse
            np.subtract(self.ddx_d, data.jdot_qdot, out=self._a)
            np.matmul(J, J.T, out=self._jjt)
            self._jjt += self._lambda2_eye
            y = solve3(self._jjt, self._a, self._y)
            np.matmul(J.T, y, out=self._ddq_act)
            self._ddq[0] = ddq1
            tau = self._tau_full
            moving = base_accel is not None and any(
                v != 0.0 for v in np.asarray(base_accel, dtype=float).reshape(3).tolist())
            tau[:] = model.rnea(data, q, dq, self._ddq, base_accel if moving else None)
            tau[1:] += J.T @ self._spring_damper()
            if self.friction_enabled and self.friction is not None:  # eq. (4)
                tau[1:] += self.friction.torque(dq[1:])
        except Exception:  # wrong shapes or types: name the input, never raise in the loop
            return self._fail(self.check_state(q, dq, ddq1, base_accel) or "controller failed on this input")
        return self._finish(tau, q, dq, ddq1, base_accel)
