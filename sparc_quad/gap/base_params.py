"""Link inertial-parameter errors as identifiable combinations (base parameters).

The joint torques are linear in every body's 10 standard dynamic parameters (pinocchio order: m, m c_x,
m c_y, m c_z, I_xx, I_xy, I_yy, I_xz, I_yz, I_zz, about the joint frame): tau = W(q, dq, ddq) phi, W from
`pin.computeJointTorqueRegressor`. Many columns of W are zero or combinations of others on a fixed-base
chain, so only base parameters can be identified: a pivoted QR of W stacked over the training samples
(`scipy.linalg.qr(W, pivoting=True)`) picks independent columns; each dependent column is a combination
of them (W_dep = W_ind B, B = R11^-1 R12), so an error in the independent parameter i really is an error
in the combination phi_i + sum_k B_ik phi_dep_k, which is what the report names.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import scipy.linalg

PARAM_NAMES = ("m", "mx", "my", "mz", "Ixx", "Ixy", "Iyy", "Ixz", "Iyz", "Izz")
RANK_TOL = 1e-7  # |R_ii| below this x |R_00|: the column depends on the ones before it


def regressor(model, q: np.ndarray, dq: np.ndarray, ddq: np.ndarray) -> np.ndarray:
    """(N, nv, 10 nbodies) joint-torque regressor at every sample."""
    data = model.createData()
    out = np.empty((q.shape[0], model.nv, 10 * (model.njoints - 1)))
    for i in range(q.shape[0]):
        out[i] = pin.computeJointTorqueRegressor(model, data, q[i], dq[i], ddq[i])
    return out


class BaseParameters:
    """Independent columns of the stacked regressor and the combinations they stand for."""

    def __init__(self, model, W: np.ndarray):
        """W: (rows, 10 nbodies) regressor stacked over samples and joints."""
        self.model = model
        scale = np.sqrt(np.sum(W**2, axis=0))
        live = scale > RANK_TOL * max(float(scale.max()), 1e-300)
        idx = np.nonzero(live)[0]
        Ws = W[:, idx] / scale[idx]
        _, R, P = scipy.linalg.qr(Ws, mode="economic", pivoting=True)
        d = np.abs(np.diag(R))
        r = int(np.sum(d > RANK_TOL * d[0])) if d.size else 0
        self.independent = [int(idx[p]) for p in P[:r]]
        self.dependent = [int(idx[p]) for p in P[r:]]
        B = scipy.linalg.solve_triangular(R[:r, :r], R[:r, r:]) if r < len(idx) else np.zeros((r, 0))
        # back to unscaled columns: W_dep = W_ind (S_ind B S_dep^-1)
        s_ind = scale[self.independent]
        s_dep = scale[self.dependent]
        self.B = (B / s_ind[:, None]) * s_dep[None, :] if B.size else B

    def body_of(self, col: int) -> int:
        """Joint id (1-based body) of a standard-parameter column."""
        return col // 10 + 1

    def columns_of(self, joint_id: int) -> list[int]:
        """Independent columns belonging to this joint's body."""
        return [c for c in self.independent if self.body_of(c) == joint_id]

    def label(self, col: int) -> str:
        return f"{PARAM_NAMES[col % 10]}[{self.model.names[self.body_of(col)]}]"

    def combination(self, col: int) -> str:
        """The combination of standard parameters the independent column `col` identifies."""
        i = self.independent.index(col)
        parts = [self.label(col)]
        if self.B.size:
            for k, dep in enumerate(self.dependent):
                c = float(self.B[i, k])
                if abs(c) > 1e-6:
                    parts.append(f"{c:+.4g} {self.label(dep)}")
        return " ".join(parts)
