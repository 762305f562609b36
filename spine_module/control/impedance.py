"""Computed-acceleration task impedance, eq. (3), with optional Stribeck compensation, eq. (4).

tau = M J†(ẍ_d − J̇q̇) + Jᵀ(D(ẋ_d − ẋ) + K(x_d − x)) + C q̇ + g (+ tau_friction)

M J† a + C q̇ + g is evaluated as one RNEA pass at the desired joint acceleration
ddq* = [q̈1, J†(ẍ_d − J̇q̇)]: mathematically the same as forming M and C, without building them. The
measured torso acceleration q̈1 enters ddq*, so torso pitching is compensated on a robot (0 on the bench).
J† = Jᵀ(JJᵀ + λ²I)⁻¹ is the damped least-squares pseudo-inverse.
"""

from __future__ import annotations

import numpy as np
from scipy.linalg.lapack import dgesv as _gesv

from spine_module import params as P
from spine_module.control.friction import StribeckFriction
from spine_module.control.output import ControlOutput, TaskController
from spine_module.model import SpineModel


class ImpedanceController(TaskController):
    def __init__(self, model: SpineModel, friction: StribeckFriction | None = None,
                 k: object = P.K_DEFAULT, d: object = P.D_DEFAULT, dls_lambda: float = P.DLS_LAMBDA) -> None:
        super().__init__(model, k, d)
        self.friction = friction
        self.friction_enabled = friction is not None  # run-time switch; needs a friction model to act
        self.lambda2 = dls_lambda**2
        self._ddq = np.zeros(model.nv)
        self._ddq_act = self._ddq[1:]
        self._a = np.zeros(3)
        self._jjt = np.zeros((3, 3))
        self._lambda2_eye = self.lambda2 * np.eye(3)

    def step(self, q: np.ndarray, dq: np.ndarray, ddq1: float = 0.0) -> ControlOutput:
        """One cycle: joint state (rad, rad/s, [q1..q4]) and torso acceleration q̈1 (rad/s²) → torques."""
        try:
            model, data = self.model, self.data
            model.update_kinematics(data, q, dq)
            J = data.J_act
            # desired task acceleration minus drift, mapped through the DLS pseudo-inverse
            np.subtract(self.ddx_d, data.jdot_qdot, out=self._a)
            np.matmul(J, J.T, out=self._jjt)
            self._jjt += self._lambda2_eye
            y = _gesv(self._jjt, self._a)[2]
            np.matmul(J.T, y, out=self._ddq_act)
            self._ddq[0] = ddq1
            tau = self._tau_full
            tau[:] = model.rnea(data, q, dq, self._ddq)
            tau[1:] += J.T @ self._spring_damper()
            if self.friction_enabled and self.friction is not None:  # eq. (4)
                tau[1:] += self.friction.torque(dq[1:])
        except Exception:  # wrong shapes or types: name the input, never raise in the loop
            return self._fail(self.check_state(q, dq, ddq1) or "controller failed on this input")
        return self._finish(tau, q, dq, ddq1)
