"""The in-memory trial (joint space) and the robot its sidecar names; no file parsing here."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from sparc_quad.gap.errors import TrialError
from sparc_quad.gap.robot import Robot, RobotError
from sparc_quad.gap.sidecar import sidecar_path


@dataclass
class Trial:
    """One log in joint space. `tau_cmd` is the input torque per actuated joint: the command
    (torque_kind commanded) or the measured torque (torque_kind measured); `tau_command` is the logged
    command beside a measured torque, when there is one."""

    path: Path  # the CSV
    meta: dict
    t: np.ndarray
    q: np.ndarray  # (N, nv) in the robot's joint order
    dq: np.ndarray
    tau_cmd: np.ndarray  # (N, na) in actuated order
    tau_meas: np.ndarray | None = None
    f_ext: np.ndarray | None = None
    robot: Robot | None = field(default=None, repr=False)
    tau_command: np.ndarray | None = None

    @property
    def name(self) -> str:
        return self.path.stem

    @property
    def rate_hz(self) -> float:
        return float(self.meta["rate_hz"])

    @property
    def dt(self) -> float:
        return 1.0 / self.rate_hz

    @property
    def torque_kind(self) -> str:
        return self.meta.get("torque_kind", "commanded")

    def plant_path(self) -> Path | None:
        p = self.meta.get("plant")
        return None if p is None else (self.path.parent / p)

    def slice(self, a: int, b: int, suffix: str) -> Trial:
        def cut(x):
            return None if x is None else x[a:b]

        return Trial(self.path.with_name(f"{self.path.stem}{suffix}.csv"), self.meta, self.t[a:b],
                     self.q[a:b], self.dq[a:b], self.tau_cmd[a:b], cut(self.tau_meas), cut(self.f_ext),
                     self.robot, cut(self.tau_command))


def robot_for(csv_path: Path, meta: dict) -> Robot:
    side = sidecar_path(csv_path)
    urdf = Path(meta["urdf"])
    if not urdf.is_absolute():
        urdf = side.parent / urdf
    try:
        return Robot(urdf.resolve(), meta["actuated_joints"], meta.get("fixed_joints", {}), meta["gravity"],
                     meta.get("ee_frame"))
    except RobotError as exc:
        raise TrialError(side, str(exc)) from exc

