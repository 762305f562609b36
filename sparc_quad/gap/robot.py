"""A fixed-base URDF as the gap workflow sees it: pinocchio model with the fixed joints locked."""

from __future__ import annotations

import logging
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pinocchio as pin

from sparc_quad.effects.plant import PlantEffects

log = logging.getLogger(__name__)
SINGULAR_REL = 1e-9  # a mass-matrix diagonal entry below this x the largest is taken as zero
CHECK_POSES = 8  # random poses (within the joint limits) at which the mass matrix is checked at load


class RobotError(ValueError):
    pass


class Robot:
    """Rigid-body model of a fixed-base chain.

    `joints`: the non-fixed joints in pinocchio's order (the trial's q_/dq_ columns);
    `actuated`: the subset with motors (tau_cmd_ columns); `act_idx`: their velocity indices.
    Every non-fixed joint must be 1-DoF (revolute or prismatic).
    """

    def __init__(self, urdf: str | Path, actuated: Sequence[str], fixed: dict[str, float] | None = None,
                 gravity: Sequence[float] = (0.0, 0.0, -9.81), ee_frame: str | None = None):
        self.urdf = str(urdf)
        try:
            full = pin.buildModelFromUrdf(self.urdf)
        except Exception as exc:  # pinocchio raises RuntimeError/ValueError on bad files
            raise RobotError(f"{urdf}: cannot load URDF: {exc}") from exc
        fixed = dict(fixed or {})
        names = list(full.names)[1:]
        for name in [*fixed, *actuated]:
            if name not in names:
                raise RobotError(f"{urdf}: joint {name!r} not in the URDF (joints: {', '.join(names)})")
        q_ref = pin.neutral(full)
        lock = []
        for name, value in fixed.items():
            jid = full.getJointId(name)
            if full.joints[jid].nq != 1:
                raise RobotError(f"{urdf}: fixed joint {name!r} is not 1-DoF")
            q_ref[full.joints[jid].idx_q] = float(value)
            lock.append(jid)
        self.model = pin.buildReducedModel(full, lock, q_ref) if lock else full
        self.model.gravity.linear = np.asarray(gravity, dtype=float)
        self.joints = list(self.model.names)[1:]
        for jid in range(1, self.model.njoints):
            j = self.model.joints[jid]
            if j.nq != 1 or j.nv != 1:
                raise RobotError(f"{urdf}: joint {self.model.names[jid]!r} is not 1-DoF (nq={j.nq})")
        self.actuated = list(actuated)
        for name in self.actuated:
            if name in fixed:
                raise RobotError(f"{urdf}: joint {name!r} is both fixed and actuated")
        self.act_idx = np.array([self.model.joints[self.model.getJointId(n)].idx_v for n in self.actuated])
        self.ee_frame = ee_frame
        if ee_frame is not None and not self.model.existFrame(ee_frame):
            raise RobotError(f"{urdf}: frame {ee_frame!r} not in the URDF")
        self.nv = self.model.nv
        self.lower = self.model.lowerPositionLimit.copy()
        self.upper = self.model.upperPositionLimit.copy()
        self.singular_joints = self.massless_joints()
        for j in self.singular_joints:
            log.warning("%s: joint %r moves no mass or inertia (link %r): its mass-matrix row is zero, "
                        "so forward dynamics (replay) needs a rotor inertia on it; inverse dynamics is "
                        "unaffected",
                        urdf, j, self.child_link(j))

    def massless_joints(self, armature: np.ndarray | None = None) -> list[str]:
        """Joints whose mass-matrix diagonal (plus `armature`, per joint) is zero at every checked pose:
        a massless distal link. Pinocchio's model as loaded (no plant effects) unless armature is given."""
        rng = np.random.default_rng(0)
        lo = np.where(np.isfinite(self.lower), self.lower, -np.pi)
        hi = np.where(np.isfinite(self.upper), self.upper, np.pi)
        data = self.model.createData()
        diag = np.zeros(self.nv)
        for k in range(CHECK_POSES):
            q = 0.5 * (lo + hi) if k == 0 else rng.uniform(lo, hi)
            diag = np.maximum(diag, np.diag(pin.crba(self.model, data, q)))
        if armature is not None:
            diag = diag + armature
        tiny = SINGULAR_REL * max(float(diag.max()), 1e-12)
        return [self.joints[v] for v in range(self.nv) if diag[v] <= tiny]

    def child_link(self, joint: str) -> str:
        """Name of the link a joint moves (first body frame attached to that joint)."""
        jid = self.model.getJointId(joint)
        for f in self.model.frames:
            if f.parentJoint == jid and f.type == pin.FrameType.BODY:
                return f.name
        return joint

    def link_com(self, joint: str) -> np.ndarray:
        return np.array(self.model.inertias[self.model.getJointId(joint)].lever)

    def link_mass(self, joint: str) -> float:
        return float(self.model.inertias[self.model.getJointId(joint)].mass)

    def plant_model(self, plant: PlantEffects | None):
        return self.model if plant is None else plant.apply_to_pinocchio(self.model)

    def forward_step(self, model, data, q: np.ndarray, dq: np.ndarray, tau: np.ndarray,
                     plant: PlantEffects, dt: float, prescribed: np.ndarray | None = None,
                     ddq_prescribed: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """One step of length dt: joint torque `tau` (without friction) held, the plant's friction
        linearly implicit at the step's midpoint velocity (stable for a sharp tanh on a light joint),
        semi-implicit Euler. Returns (q, dq) after the step.

        The friction applied is f(dq_k) + f'(dq_k) (dq_k+1 - dq_k) / 2 ~ f((dq_k + dq_k+1) / 2), which is
        what the inverse-dynamics residual evaluates.
        `prescribed` (velocity indices) with `ddq_prescribed`: those joints follow the given acceleration
        (a joint with no inertia cannot be integrated); the others are solved with it as a known input.
        Raises np.linalg.LinAlgError if the (remaining) mass matrix is singular.
        """
        act = self.act_idx
        M = pin.crba(model, data, q)
        M = np.triu(M) + np.triu(M, 1).T
        M[np.ix_(act, act)] += plant.coupled_M
        h = pin.rnea(model, data, q, dq, np.zeros(self.nv))
        rhs = tau - h
        fr, slope = plant.friction_and_slope(dq[act])
        rhs[act] += fr
        mjj = np.diag(M)[act]
        M[act, act] += 0.5 * dt * np.maximum(slope, -mjj / dt)
        if prescribed is not None and len(prescribed):
            free = np.setdiff1d(np.arange(self.nv), prescribed)
            ddq = np.zeros(self.nv)
            ddq[prescribed] = ddq_prescribed
            ddq[free] = np.linalg.solve(M[np.ix_(free, free)], rhs[free] - M[np.ix_(free, prescribed)]
                                        @ ddq_prescribed)
        else:
            ddq = np.linalg.solve(M, rhs)
        dq = dq + dt * ddq
        return q + dt * dq, dq

    # ---- batched dynamics ------------------------------------------------------------------------
    @staticmethod
    def rnea(model, q: np.ndarray, dq: np.ndarray, ddq: np.ndarray) -> np.ndarray:
        data = model.createData()
        out = np.empty_like(q)
        for i in range(q.shape[0]):
            out[i] = pin.rnea(model, data, q[i], dq[i], ddq[i])
        return out

    def ext_torque(self, q: np.ndarray, f_ext: np.ndarray | None) -> np.ndarray:
        """J^T w for a planar wrench (f_x, f_z, m_y) in the base frame at ee_frame; zeros without one."""
        out = np.zeros_like(q)
        if f_ext is None or self.ee_frame is None:
            return out
        model = self.model
        data = model.createData()
        fid = model.getFrameId(self.ee_frame)
        for i in range(q.shape[0]):
            pin.computeJointJacobians(model, data, q[i])
            pin.updateFramePlacements(model, data)
            J = pin.getFrameJacobian(model, data, fid, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED)
            w = np.array([f_ext[i, 0], 0.0, f_ext[i, 1], 0.0, f_ext[i, 2], 0.0])
            out[i] = J.T @ w
        return out

    def rnea_dq(self, model, q, dq, ddq) -> np.ndarray:
        """d tau / d q for every sample: (N, nv, nv)."""
        data = model.createData()
        out = np.empty((q.shape[0], self.nv, self.nv))
        for i in range(q.shape[0]):
            pin.computeRNEADerivatives(model, data, q[i], dq[i], ddq[i])
            out[i] = data.dtau_dq
        return out

    def point_mass_column(self, model, joint: str, xyz: np.ndarray, q, dq, ddq) -> np.ndarray:
        """Joint torques of a unit point mass at xyz on `joint`'s child link: (N, nv)."""
        data = model.createData()
        jid = model.getJointId(joint)
        pi = pin.Inertia(1.0, np.asarray(xyz, float), np.zeros((3, 3))).toDynamicParameters()
        sl = slice(10 * (jid - 1), 10 * jid)
        out = np.empty_like(q)
        for i in range(q.shape[0]):
            Y = pin.computeJointTorqueRegressor(model, data, q[i], dq[i], ddq[i])
            out[i] = Y[:, sl] @ pi
        return out
