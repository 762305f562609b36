"""The quadruped world in pybullet: DIRECT, torque control on every joint (default velocity motors off),
an infinite plane tilted about y for the slope.

One `PybulletWorld` owns one pybullet client; nothing global is touched, so worlds can run side by side
(a stiffness study fans them out). The shared state, estimator and torque ordering are QuadWorld's.
"""

from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np
import pybullet_data

from sparc_quad.robots import ROBOTS_DIR
from sparc_quad.sim.pybullet_quiet import pb
from sparc_quad.sim.quadruped_world import (
    ABSENT,
    QuadWorld,
    WorldConfig,
    pitch_of,
    quat_about_y,
)


class PybulletWorld(QuadWorld):
    """One pybullet world with the spined quadruped standing on its four feet at t = 0."""

    engine = "pybullet"

    def __init__(self, cfg: WorldConfig | None = None, robots_dir: Path = ROBOTS_DIR):
        super().__init__(cfg, robots_dir)
        cfg, files = self.cfg, self.files
        urdf_path = files.urdf
        self.client = pb.connect(pb.DIRECT)
        c = self.client
        pb.resetSimulation(physicsClientId=c)
        pb.setGravity(0, 0, -cfg.gravity_m_s2, physicsClientId=c)
        pb.setTimeStep(cfg.dt_s, physicsClientId=c)
        pb.setPhysicsEngineParameter(
            numSolverIterations=cfg.solver_iterations, deterministicOverlappingPairs=1, physicsClientId=c
        )
        # The ground: an infinite plane through the origin, tilted about y; rising along +x when slope > 0.
        self.ground = pb.loadURDF(
            str(Path(pybullet_data.getDataPath()) / "plane.urdf"),
            [0, 0, 0],
            quat_about_y(-cfg.slope_rad),
            physicsClientId=c,
        )
        pb.changeDynamics(self.ground, -1, lateralFriction=cfg.friction, physicsClientId=c)
        self.robot = pb.loadURDF(
            str(urdf_path), [0, 0, 1.0], flags=pb.URDF_USE_INERTIA_FROM_FILE, physicsClientId=c
        )
        joint_index: dict[str, int] = {}
        self.link_index: dict[str, int] = {self.meta["base_link"]: -1}
        for i in range(pb.getNumJoints(self.robot, physicsClientId=c)):
            info = pb.getJointInfo(self.robot, i, physicsClientId=c)
            self.link_index[info[12].decode()] = i
            if info[2] == pb.JOINT_REVOLUTE:
                joint_index[info[1].decode()] = i
        self._index_joints(joint_index)
        self.engine_joints = [j for j in self.movable if j != ABSENT]  # the joints pybullet drives
        self._pad = (0.0,) * (len(self.movable) - len(self.engine_joints))  # an absent joint reads 0
        # Default velocity motors off: every joint is torque controlled.
        # Joint dry friction (`joint_friction_nm`): the velocity motors kept at target 0 with that force
        # limit, which the solver applies as a friction constraint beside the torques.
        pb.setJointMotorControlArray(self.robot, self.engine_joints, pb.VELOCITY_CONTROL,
                                     forces=[cfg.joint_friction_nm] * len(self.engine_joints),
                                     physicsClientId=c)
        for link in range(-1, pb.getNumJoints(self.robot, physicsClientId=c)):
            pb.changeDynamics(
                self.robot, link, linearDamping=0.0, angularDamping=0.0,
                jointDamping=cfg.joint_damping_nm_s_rad if link >= 0 else 0.0, physicsClientId=c
            )
            if cfg.mass_scale != 1.0:
                info = pb.getDynamicsInfo(self.robot, link, physicsClientId=c)
                pb.changeDynamics(self.robot, link, mass=info[0] * cfg.mass_scale,
                                  localInertiaDiagonal=[v * cfg.mass_scale for v in info[2]],
                                  physicsClientId=c)
        self.foot_links = {self.link_index[v["foot_link"]]: k for k, v in self.legs.items()}
        parent = {
            i: pb.getJointInfo(self.robot, i, physicsClientId=c)[16]
            for i in range(pb.getNumJoints(self.robot, physicsClientId=c))
        }
        leg_roots = {self.joint_index[v["haa"] or v["hfe"]] for v in self.legs.values()}
        leg_links = set()
        for i in parent:
            j = i
            while j != -1 and j not in leg_roots:
                j = parent[j]
            if j != -1:
                leg_links.add(i)
        self.body_links = {i for i in self.link_index.values() if i not in leg_links}
        for link in self.foot_links:
            pb.changeDynamics(self.robot, link, lateralFriction=cfg.friction, physicsClientId=c)
        dyn = pb.getDynamicsInfo(self.robot, -1, physicsClientId=c)
        self._base_inertial_pos = np.array(dyn[3])
        self._base_inertial_xyz = tuple(float(v) for v in dyn[3])  # plain floats for the per-step read
        self._link_mass = [pb.getDynamicsInfo(self.robot, i, physicsClientId=c)[0]
                           for i in range(-1, pb.getNumJoints(self.robot, physicsClientId=c))]
        self.total_mass = sum(self._link_mass)
        self._links = list(range(pb.getNumJoints(self.robot, physicsClientId=c)))
        self.reset_stand(pitch_rad=-cfg.slope_rad + cfg.init_pitch_rad)
        if cfg.init_vx_m_s:
            pb.resetBaseVelocity(self.robot, [cfg.init_vx_m_s, 0, 0], [0, 0, 0], physicsClientId=c)
            self.read()
        self.spine_locks = self._lock_spine() if cfg.lock_spine else []

    def _lock_spine(self) -> list[int]:
        """Fixed constraints between consecutive spine links at their present relative poses (or at
        `lock_spine_q_rad`): q2..q4 locked (a rigid spine, not a stiff controller). Returns the ids."""
        c = self.client
        if self.cfg.lock_spine_q_rad is not None:
            for j, q in zip(self.spine_idx, self.cfg.lock_spine_q_rad, strict=True):
                pb.resetJointState(self.robot, j, q, 0.0, physicsClientId=c)

        def com_pose(link: int):
            if link == -1:
                return pb.getBasePositionAndOrientation(self.robot, physicsClientId=c)
            st = pb.getLinkState(self.robot, link, computeForwardKinematics=1, physicsClientId=c)
            return st[0], st[1]

        ids = []
        for j in self.spine_idx:
            parent = pb.getJointInfo(self.robot, j, physicsClientId=c)[16]
            pp, po = com_pose(parent)
            cp, co = com_pose(j)
            ip, io = pb.invertTransform(pp, po)
            rel_p, rel_o = pb.multiplyTransforms(ip, io, cp, co)
            uid = pb.createConstraint(self.robot, parent, self.robot, j, pb.JOINT_FIXED, [0, 0, 0],
                                      rel_p, [0, 0, 0], rel_o, [0, 0, 0, 1], physicsClientId=c)
            pb.changeConstraint(uid, maxForce=1e5, physicsClientId=c)
            ids.append(uid)
        return ids

    # ---- set-up ---------------------------------------------------------------------------------------
    def reset_stand(self, pitch_rad: float | None = None) -> None:
        """Place the robot on its feet, spine at equilibrium, body parallel to the ground, at rest."""
        c = self.client
        cfg = self.cfg
        pitch = -cfg.slope_rad if pitch_rad is None else pitch_rad
        q_spine, legs = self.stand_pose()
        for name, q in zip(self.meta["spine_joints"], q_spine, strict=True):
            pb.resetJointState(self.robot, self.joint_index[name], q, 0.0, physicsClientId=c)
        for key, (haa, hfe, kfe) in self.leg_idx.items():
            hq, kq = legs[key]
            if haa != ABSENT:
                pb.resetJointState(self.robot, haa, 0.0, 0.0, physicsClientId=c)
            pb.resetJointState(self.robot, hfe, hq, 0.0, physicsClientId=c)
            pb.resetJointState(self.robot, kfe, kq, 0.0, physicsClientId=c)
        # hind body frame: hips at height h + r above the ground, measured along the ground normal
        quat = quat_about_y(pitch)
        n = (math.sin(-cfg.slope_rad), 0.0, math.cos(-cfg.slope_rad))  # ground normal
        frame = np.array(n) * self.stand_frame_height_m()
        rot = np.array(pb.getMatrixFromQuaternion(quat)).reshape(3, 3)
        com = frame + rot @ self._base_inertial_pos
        pb.resetBasePositionAndOrientation(self.robot, com.tolist(), quat, physicsClientId=c)
        pb.resetBaseVelocity(self.robot, [0, 0, 0], [0, 0, 0], physicsClientId=c)
        self.t = 0.0
        self.steps = 0
        self.read()

    def com_x(self) -> float:
        """World x of the whole robot's centre of mass."""
        c = self.client
        total = self.total_mass
        com = pb.getBasePositionAndOrientation(self.robot, physicsClientId=c)[0]
        acc = pb.getDynamicsInfo(self.robot, -1, physicsClientId=c)[0] * com[0]
        for i in range(pb.getNumJoints(self.robot, physicsClientId=c)):
            m = pb.getDynamicsInfo(self.robot, i, physicsClientId=c)[0]
            acc += m * pb.getLinkState(self.robot, i, computeForwardKinematics=1, physicsClientId=c)[0][0]
        return acc / total

    # ---- state ---------------------------------------------------------------------------------------
    def read(self) -> None:
        """Refresh the true state (sim side) from pybullet."""
        c = self.client
        com, quat = pb.getBasePositionAndOrientation(self.robot, physicsClientId=c)
        v, w = pb.getBaseVelocity(self.robot, physicsClientId=c)
        rot = pb.getMatrixFromQuaternion(quat)
        bx, by, bz = self._base_inertial_xyz
        # frame origin = com - R * local inertial offset; velocity likewise (omega x r)
        rx = rot[0] * bx + rot[1] * by + rot[2] * bz
        ry = rot[3] * bx + rot[4] * by + rot[5] * bz
        rz = rot[6] * bx + rot[7] * by + rot[8] * bz
        self.base_pos = (com[0] - rx, com[1] - ry, com[2] - rz)
        self.base_vel = (
            v[0] - (w[1] * rz - w[2] * ry),
            v[1] - (w[2] * rx - w[0] * rz),
            v[2] - (w[0] * ry - w[1] * rx),
        )
        self.base_quat = quat
        self.base_rot = rot
        self.base_omega = w
        self.q1 = pitch_of(quat)
        self.dq1 = w[1]
        self.roll = math.atan2(rot[7], rot[8])
        self.yaw = math.atan2(rot[3], rot[0])
        # positions and rates in one pass in C (tuples: nothing downstream writes into them)
        js = pb.getJointStates(self.robot, self.engine_joints, physicsClientId=c)
        jq, jdq, _, _ = zip(*js, strict=True)
        pad = self._pad
        if pad:
            jq, jdq = jq + pad, jdq + pad
        self.jq, self.jdq = jq, jdq
        spine = self._spine_of
        self.q_spine = spine(jq)
        self.dq_spine = spine(jdq)
        contacts = pb.getContactPoints(bodyA=self.robot, bodyB=self.ground, physicsClientId=c)
        self.contact_force = force = dict.fromkeys(self.legs, 0.0)
        self.other_contact = False
        self.body_contact = False
        feet = self.foot_links
        for cp in contacts:
            key = feet.get(cp[3])
            if key is None:
                self.other_contact = True
                self.body_contact |= cp[3] in self.body_links
            else:
                force[key] += cp[9]

    def _robot_com(self, states) -> tuple[float, float, float]:
        """The whole robot's centre of mass (world, m) from the base and `getLinkStates`' link COMs."""
        mass = self._link_mass
        bx, by, bz = pb.getBasePositionAndOrientation(self.robot, physicsClientId=self.client)[0]
        cx, cy, cz = mass[0] * bx, mass[0] * by, mass[0] * bz
        for k, st in enumerate(states, start=1):
            px, py, pz = st[0]  # the link's COM
            cx, cy, cz = cx + mass[k] * px, cy + mass[k] * py, cz + mass[k] * pz
        total = self.total_mass
        return cx / total, cy / total, cz / total

    def authors_twist(self) -> tuple[float, ...]:
        """`QuadWorld.authors_twist` of the present state (`cvel_lag_steps` 0: the estimator's delay makes it
        the previous step's, as MuJoCo's `cvel` is): the velocity of the point at the whole robot's centre of
        mass moving rigidly with the hind body, v_origin + w x (com - origin), and w, world axes."""
        states = pb.getLinkStates(self.robot, self._links, computeForwardKinematics=1,
                                  physicsClientId=self.client)
        cx, cy, cz = self._robot_com(states)
        ox, oy, oz = self.base_pos
        rx, ry, rz = cx - ox, cy - oy, cz - oz
        vx, vy, vz = self.base_vel
        wx, wy, wz = self.base_omega
        return (vx + wy * rz - wz * ry, vy + wz * rx - wx * rz, vz + wx * ry - wy * rx, wx, wy, wz)

    def authors_body_states(self) -> tuple:
        """`QuadWorld.authors_body_states` of the present state (no lag: pybullet has no cvel), as MuJoCo
        defines its `cvel` linear part: v_com(link) + w x (com(robot) - com(link))."""
        c, robot = self.client, self.robot
        states = pb.getLinkStates(robot, self._links, computeLinkVelocity=1, computeForwardKinematics=1,
                                  physicsClientId=c)
        com = self._robot_com(states)

        def at_com(p, v, w):
            rx, ry, rz = com[0] - p[0], com[1] - p[1], com[2] - p[2]
            return (v[0] + w[1] * rz - w[2] * ry, v[1] + w[2] * rx - w[0] * rz, v[2] + w[0] * ry - w[1] * rx)

        base_com = pb.getBasePositionAndOrientation(robot, physicsClientId=c)[0]
        lin, ang = pb.getBaseVelocity(robot, physicsClientId=c)
        front = states[self.spine_idx[-1]]
        front_rot = tuple(pb.getMatrixFromQuaternion(front[5]))
        return (tuple(self.base_pos), tuple(self.base_rot), at_com(base_com, lin, ang), tuple(ang), front_rot,
                at_com(front[0], front[6], front[7]))

    def step(self) -> None:
        tau = self._tau if not self._pad else self._tau[:self.n_engine_joints]
        pb.setJointMotorControlArray(
            self.robot, self.engine_joints, pb.TORQUE_CONTROL, forces=tau, physicsClientId=self.client
        )
        t0 = time.perf_counter()
        pb.stepSimulation(physicsClientId=self.client)
        self.physics_wall_s += time.perf_counter() - t0
        self.steps += 1
        self.t = self.steps * self.cfg.dt_s
        self.read()

    def close(self) -> None:
        if self.client is not None and pb.isConnected(self.client):
            pb.disconnect(self.client)
        self.client = None

    # ---- rendering -----------------------------------------------------------------------------------
    def render(self, width: int = 480, height: int = 320) -> np.ndarray:
        """An RGB frame from pybullet's software renderer (ER_TINY_RENDERER), camera following the robot."""
        x, y, z = self.base_pos
        view = pb.computeViewMatrixFromYawPitchRoll(
            [x + 0.15, y, z - 0.05], 0.9, 0.0, -10.0, 0.0, 2, physicsClientId=self.client
        )
        proj = pb.computeProjectionMatrixFOV(50.0, width / height, 0.05, 10.0, physicsClientId=self.client)
        img = pb.getCameraImage(
            width, height, view, proj, renderer=pb.ER_TINY_RENDERER, physicsClientId=self.client
        )
        rgba = np.reshape(np.asarray(img[2], dtype=np.uint8), (height, width, 4))
        return rgba[:, :, :3].copy()
