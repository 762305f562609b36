"""Smooth Stribeck friction, eq. (4), per joint: a compensator on the robot, the truth in a simulation."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from spine_module import params as P


class StribeckFriction:
    """tau_f(dq) = (tau_c + (tau_s - tau_c) exp(-(|dq|/dq_s)^alpha)) tanh(beta dq) + b dq, N*m.

    One parameter set per actuated joint. `torque(dq)` writes into a preallocated buffer and returns it.
    """

    def __init__(self, joints: Sequence[P.StribeckParams]) -> None:
        self.params = tuple(joints)
        self.tau_c = np.array([p.tau_c_nm for p in joints])
        self.tau_s = np.array([p.tau_s_nm for p in joints])
        self.b = np.array([p.b_nm_s_rad for p in joints])
        self.inv_dq_s = 1.0 / np.abs(np.array([p.dq_s_rad_s for p in joints]))
        self.alpha = np.array([p.alpha for p in joints])
        self.beta = np.array([p.beta_s_rad for p in joints])
        if np.any(self.inv_dq_s <= 0) or np.any(self.alpha <= 0) or np.any(self.beta <= 0):
            raise ValueError("Stribeck velocity, alpha and beta must be positive")
        self._rows = [(p.tau_c_nm, p.tau_s_nm - p.tau_c_nm, 1.0 / abs(p.dq_s_rad_s), p.alpha, p.beta_s_rad,
                       p.b_nm_s_rad) for p in self.params]
        self._out = np.zeros(len(self.params))

    def coefficient_rows(self) -> np.ndarray:
        """(joints, 6): tau_c, tau_s - tau_c, 1/dq_s, alpha, beta, b per joint (compiled step's layout)."""
        return np.array(self._rows, dtype=float)

    @classmethod
    def nominal(cls, n: int = len(P.ACTUATED_JOINTS)) -> StribeckFriction:
        """The compensator's identified estimate (params.NOMINAL_FRICTION on every joint)."""
        return cls([P.NOMINAL_FRICTION] * n)

    def scaled(self, **factors: float) -> StribeckFriction:
        """Each joint's parameters scaled as `StribeckParams.scaled` (coulomb=, static=, viscous=, ...)."""
        return StribeckFriction([p.scaled(**factors) for p in self.params])

    def torque(self, dq: np.ndarray) -> np.ndarray:
        # three scalars: plain floats beat a dozen numpy temporaries in the 1 kHz loop
        out = self._out
        for i, (v, p) in enumerate(zip(dq.tolist(), self._rows, strict=True)):
            tau_c, dtau, inv_vs, alpha, beta, b = p
            out[i] = (tau_c + dtau * math.exp(-((abs(v) * inv_vs) ** alpha))) * math.tanh(beta * v) + b * v
        return out

    def slope(self, dq: np.ndarray) -> np.ndarray:
        """d tau_f / d dq (N*m*s/rad), used by a simulation to integrate friction semi-implicitly."""
        v = np.abs(dq) * self.inv_dq_s
        decay = np.exp(-(v**self.alpha))
        th = np.tanh(self.beta * dq)
        level = self.tau_c + (self.tau_s - self.tau_c) * decay
        with np.errstate(divide="ignore", invalid="ignore"):
            dlevel = np.where(v > 0, -(self.tau_s - self.tau_c) * decay * self.alpha * v ** (self.alpha - 1)
                              * self.inv_dq_s * np.sign(dq), 0.0)
        return dlevel * th + level * self.beta * (1.0 - th**2) + self.b
