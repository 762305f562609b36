"""What drives the spine joints in the quadruped sim: the SPARC impedance controller (in process, fed by
the emulated estimator's q1) or, for the rigid-spine baseline, a stiff joint PD holding the equilibrium."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from spine_module import params as P


@dataclass(frozen=True)
class SpineGains:
    k: tuple[float, float, float] = tuple(P.K_DEFAULT)  # k_x N/m, k_z N/m, k_theta N*m/rad
    d: tuple[float, float, float] = tuple(P.D_DEFAULT)  # d_x N*s/m, d_z N*s/m, d_theta N*m*s/rad


class RigidSpine:
    """Rigid-spine baseline: a joint PD stiff enough that the arch stays at equilibrium (no torque limit:
    this is the hypothetical rigid robot, not the SPARC actuators)."""

    name = "rigid"

    def __init__(self, kp: float = 1000.0, kd: float = 2.0):
        self.kp, self.kd = kp, kd
        self.q_eq = [float(v) for v in P.Q_EQUILIBRIUM[1:]]
        self.tau = np.zeros(3)
        self.kinematics = TaskKinematics()
        self.x, self.dx = self.kinematics.x, self.kinematics.dx
        self.ok = True

    def step(self, q: np.ndarray, dq: np.ndarray, ddq1: float) -> np.ndarray:
        for i in range(3):
            self.tau[i] = self.kp * (self.q_eq[i] - q[i + 1]) - self.kd * dq[i + 1]
        self.kinematics.update(q, dq)
        return self.tau


class TaskKinematics:
    """The spine's task pose and velocity (x, z, theta in the hind-body frame) from `SpineModel`, for
    drives that run no task controller of their own. `x` and `dx` are updated in place."""

    def __init__(self) -> None:
        from spine_module.model import SpineModel

        self.model = SpineModel()
        self.data = self.model.create_data()
        self.x, self.dx = self.data.x, self.data.dx

    def update(self, q: np.ndarray, dq: np.ndarray) -> None:
        self.model.update_kinematics(self.data, np.asarray(q, dtype=float), np.asarray(dq, dtype=float))


class ImpedanceSpine:
    """The SPARC impedance controller (spine_module.control) driving the spine in process."""

    name = "impedance"

    def __init__(self, gains: SpineGains, friction: bool = False):
        from spine_module.control import ImpedanceController, StribeckFriction
        from spine_module.model import SpineModel

        self.ctrl = ImpedanceController(
            SpineModel(), friction=StribeckFriction.nominal() if friction else None
        )
        self.ctrl.set_gains(k=gains.k, d=gains.d)
        self.ctrl.set_target(x_d=tuple(P.X_EQUILIBRIUM), dx_d=(0.0, 0.0, 0.0), ddx_d=(0.0, 0.0, 0.0))
        self.tau = np.zeros(3)
        self.x = np.zeros(3)
        self.dx = np.zeros(3)
        self.ok = True

    def step(self, q: np.ndarray, dq: np.ndarray, ddq1: float) -> np.ndarray:
        out = self.ctrl.step(q, dq, ddq1=ddq1)
        self.tau[:] = out.tau
        self.x[:] = out.x
        self.dx[:] = out.dx
        self.ok = bool(out.ok)
        return self.tau


def make_spine_drive(gains: SpineGains, rigid: bool = False, friction: bool = False):
    """The drive a bound uses: rigid PD, else the SPARC impedance controller."""
    if rigid:
        return RigidSpine()
    return ImpedanceSpine(gains, friction=friction)
