"""The SPARC spine as a pinocchio model: task pose, Jacobian, J̇q̇, and M, Cq̇, g from RNEA passes.

Following pinocchio, the immutable `SpineModel` (built once from the parameters) is split from the
`SpineData` workspace that a controller preallocates and reuses every cycle.

Task space (x, z, theta) is the pose of the end-effector frame (tip of the front body) in the hind body's
frame: x forward (m), z up (m), theta pitch about +y (rad). Because it is relative to the hind body, it
does not depend on q1; q1 and its rates enter only the dynamics (gravity direction, torso pitching).
Kinematics are therefore evaluated on a reduced model with q1 locked at 0 (pinocchio's
`buildReducedModel`), whose world frame is the hind-body frame.
"""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin

from spine_module import params as P
from spine_module.urdf import spine_urdf

_LWA = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
# x, z (linear) and pitch about y (angular) are rows 0, 2, 4 of a 6-D spatial quantity: a [0::2] slice
TASK_ROWS = slice(0, 6, 2)


def _write_pose(x: np.ndarray, oMf: pin.SE3) -> None:
    """Task pose (x m, z m, pitch rad) of an end-effector placement, written into `x`."""
    t, R = oMf.translation, oMf.rotation
    x[0] = t[0]
    x[1] = t[2]
    x[2] = math.atan2(R[0, 2], R[0, 0])
N_ACT = len(P.ACTUATED_JOINTS)


class SpineData:
    """Preallocated workspace of one controller: pinocchio Data for kinematics and dynamics."""

    def __init__(self, model: pin.Model, kin_model: pin.Model) -> None:
        self.kin = kin_model.createData()  # relative kinematics (q1 locked at 0)
        self.dyn = model.createData()  # dynamics at the true q1
        self.zero_v = np.zeros(model.nv)
        self.zero_act = np.zeros(kin_model.nv)
        self.J = np.zeros((3, model.nv))  # task Jacobian, column 0 (q1) is zero by construction
        self.J_act = self.J[:, 1:]  # view: the actuated columns
        self.jdot_qdot = np.zeros(3)
        # the dynamics model with gravity g - a: RNEA of a base whose origin accelerates at a
        # (SpineModel.rnea)
        self.moving_model = model.copy()
        self.x = np.zeros(3)
        self.dx = np.zeros(3)


class SpineModel:
    """Immutable model of the chain q1 (base) → q2 → q3 → q4 → end effector."""

    def __init__(self, spine: P.SpineParams = P.DEFAULT_SPINE, gravity_m_s2: float = P.GRAVITY_M_S2) -> None:
        self.spine = spine
        self.urdf = spine_urdf(spine)
        self.model: pin.Model = pin.buildModelFromXML(self.urdf)
        self.model.gravity.linear = np.array([0.0, 0.0, -gravity_m_s2])
        # URDF has no armature; the actuators' reflected rotor inertia enters M on the actuated joints
        self.model.armature[1:] = spine.armature_kg_m2
        self.kin_model: pin.Model = pin.buildReducedModel(self.model, [1], np.zeros(self.model.nq))
        self.ee_frame = self.kin_model.getFrameId(P.EE_FRAME)
        self.joint_names = tuple(self.model.names[1:])
        if self.joint_names != P.ALL_JOINTS:
            raise ValueError(f"unexpected joint order {self.joint_names}, want {P.ALL_JOINTS}")
        self.nq = self.model.nq
        self.nv = self.model.nv
        self.torque_limit_nm = np.full(N_ACT, spine.torque_limit_nm)
        self.lower_rad = self.model.lowerPositionLimit.copy()
        self.upper_rad = self.model.upperPositionLimit.copy()

    def create_data(self) -> SpineData:
        return SpineData(self.model, self.kin_model)

    # --- kinematics (relative to the hind body) ------------------------------------------------------
    def update_kinematics(self, data: SpineData, q: np.ndarray, dq: np.ndarray) -> None:
        """Fill data.x, data.dx, data.J and data.jdot_qdot for the state (q, dq) (rad, rad/s)."""
        kin_model, kin, fid = self.kin_model, data.kin, self.ee_frame
        q_act, dq_act = q[1:], dq[1:]
        pin.forwardKinematics(kin_model, kin, q_act, dq_act, data.zero_act)
        pin.computeJointJacobians(kin_model, kin)
        _write_pose(data.x, pin.updateFramePlacement(kin_model, kin, fid))
        data.J_act[:] = pin.getFrameJacobian(kin_model, kin, fid, _LWA)[TASK_ROWS]
        data.jdot_qdot[:] = pin.getFrameClassicalAcceleration(kin_model, kin, fid, _LWA).vector[TASK_ROWS]
        np.dot(data.J_act, dq_act, out=data.dx)

    def update_pose(self, data: SpineData, q: np.ndarray) -> None:
        """Fill data.x only (placements, no Jacobians): the same numbers as `update_kinematics` gives x, at
        a third of its cost, for callers that log the pose (the robot side of a co-simulation)."""
        kin_model, kin, fid = self.kin_model, data.kin, self.ee_frame
        pin.forwardKinematics(kin_model, kin, q[1:])
        _write_pose(data.x, pin.updateFramePlacement(kin_model, kin, fid))

    def task_pose(self, q: np.ndarray, data: SpineData | None = None) -> np.ndarray:
        """Task pose (x m, z m, theta rad) of the end effector in the hind-body frame."""
        data = data or self.create_data()
        self.update_kinematics(data, q, np.zeros(self.model.nv))
        return data.x.copy()

    def task_jacobian(self, q: np.ndarray, data: SpineData | None = None) -> np.ndarray:
        data = data or self.create_data()
        self.update_kinematics(data, q, np.zeros(self.model.nv))
        return data.J.copy()

    def inverse_kinematics(self, x: np.ndarray, q0: np.ndarray | None = None, tol: float = 1e-12,
                           max_iter: int = 100) -> np.ndarray:
        """Joint angles that put the end effector at task pose x (q1 kept from q0). Newton iterations."""
        q = (P.Q_EQUILIBRIUM if q0 is None else np.asarray(q0, dtype=float)).copy()
        data = self.create_data()
        for _ in range(max_iter):
            self.update_kinematics(data, q, np.zeros(self.model.nv))
            err = np.asarray(x, dtype=float) - data.x
            if float(np.max(np.abs(err))) < tol:
                return q
            q[1:] += np.linalg.solve(data.J[:, 1:], err)
        raise ValueError(f"inverse kinematics did not converge for x={x}")

    # --- dynamics from RNEA passes (the paper's approach) ---------------------------------------------
    def rnea(self, data: SpineData, q: np.ndarray, dq: np.ndarray, ddq: np.ndarray,
             base_accel: np.ndarray | None = None) -> np.ndarray:
        """Joint torques M(q) ddq + C(q, dq) dq + g(q), N*m, one RNEA pass.

        `base_accel`: linear acceleration of the base joint's origin (q1's), m/s^2, in the base body's frame
        (the hind body), gravity not included; None: a fixed origin (the paper's model). A uniformly
        accelerating base is the same as gravity g - a: the pass runs on `data.moving_model`, whose gravity
        is set to g - R a (R: the base body's orientation at q)."""
        if base_accel is None:
            return pin.rnea(self.model, data.dyn, q, dq, ddq)
        pin.forwardKinematics(self.model, data.dyn, q)
        moving = data.moving_model
        moving.gravity.linear = self.model.gravity.linear - data.dyn.oMi[1].rotation @ np.asarray(base_accel,
                                                                                                  dtype=float)
        return pin.rnea(moving, data.dyn, q, dq, ddq)

    def gravity(self, data: SpineData, q: np.ndarray) -> np.ndarray:
        """g(q) = RNEA(q, 0, 0)."""
        return self.rnea(data, q, data.zero_v, data.zero_v).copy()

    def bias(self, data: SpineData, q: np.ndarray, dq: np.ndarray) -> np.ndarray:
        """C(q, dq) dq + g(q) = RNEA(q, dq, 0)."""
        return self.rnea(data, q, dq, data.zero_v).copy()

    def mass_matrix(self, data: SpineData, q: np.ndarray) -> np.ndarray:
        """M(q), column i = RNEA(q, 0, e_i) - g(q): nv + 1 RNEA passes."""
        nv = self.model.nv
        g = self.gravity(data, q)
        M = np.empty((nv, nv))
        e = np.zeros(nv)
        for i in range(nv):
            e[:] = 0.0
            e[i] = 1.0
            M[:, i] = self.rnea(data, q, data.zero_v, e) - g
        return M

    def task_inertia(self, q: np.ndarray) -> np.ndarray:
        """Λ(q) = (J M⁻¹ Jᵀ)⁻¹ of the actuated chain (hind body fixed), kg / kg*m² blocks."""
        data = self.create_data()
        self.update_kinematics(data, q, np.zeros(self.model.nv))
        M = self.mass_matrix(data, q)[1:, 1:]
        J = data.J[:, 1:]
        return np.linalg.inv(J @ np.linalg.solve(M, J.T))

    def modal_mass_x(self, q: np.ndarray, k: np.ndarray) -> float:
        """Effective mass of the x-dominant mode of the rendered spring Λ ẍ + K x = 0, kg: k_x / ω².

        Under eq. 3 the three task axes share the non-diagonal Λ, so an x release also moves θ and z;
        this mass, unlike 1/(J M⁻¹ Jᵀ)_xx, gives that mode's period.
        """
        K = np.diag(np.asarray(k, dtype=float))
        w2, vecs = np.linalg.eig(np.linalg.solve(self.task_inertia(q), K))
        mode = int(np.argmax(np.abs(vecs[0]) / np.abs(vecs).max(axis=0)))
        return float(K[0, 0] / w2[mode].real)

    def effective_mass_x(self, q: np.ndarray) -> float:
        """Apparent mass along task x: 1 / (J M⁻¹ Jᵀ)_xx, kg. What an x-only push feels (Fig. 5 ideal)."""
        data = self.create_data()
        self.update_kinematics(data, q, np.zeros(self.model.nv))
        M = self.mass_matrix(data, q)[1:, 1:]
        J = data.J[:, 1:]
        return 1.0 / float((J @ np.linalg.solve(M, J.T))[0, 0])
