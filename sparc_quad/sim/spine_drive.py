"""What drives the spine joints in the quadruped sim: the SPARC impedance controller (in process, fed by
the emulated estimator's q1) or, for the rigid-spine baseline, a stiff joint PD holding the equilibrium."""

from __future__ import annotations

import math
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
        self.x = np.array(P.X_EQUILIBRIUM, dtype=float)
        self.dx = np.zeros(3)
        self.ok = True

    def step(self, q: np.ndarray, dq: np.ndarray, ddq1: float) -> np.ndarray:
        for i in range(3):
            self.tau[i] = self.kp * (self.q_eq[i] - q[i + 1]) - self.kd * dq[i + 1]
        self.x[:] = planar_task_pose(q)
        return self.tau


def planar_task_pose(q) -> tuple[float, float, float]:
    """Front body tip (x, z, theta) in the hind body frame; z up, theta about +y (same chain as the URDF)."""
    hb, hs, fs, fb = P.DEFAULT_SPINE.links
    x = hb.length_m
    z = 0.0
    a = 0.0
    for qi, link in ((q[1], hs), (q[2], fs), (q[3], fb)):
        a += qi
        x += link.length_m * math.cos(a)
        z -= link.length_m * math.sin(a)
    return x, z, a


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
