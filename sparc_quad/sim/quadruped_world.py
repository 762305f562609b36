"""The spined quadruped in pybullet: DIRECT, 1 kHz, torque control on every joint, flat or sloped ground,
and an emulation of the torso state estimator (q1 and its rates from a simulated IMU on the hind body).

One `QuadrupedWorld` owns one pybullet client; nothing global is touched, so worlds can run side by side
(a stiffness study fans them out). Every random number comes from the world's own seeded generator.

Conventions: world x forward (down the slope's rising direction), z up; pitch about +y, positive nose
down (the spine model's q1 convention). q1 is the hind body's pitch relative to gravity.
"""

from __future__ import annotations

import collections
import json
import math
import operator
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pybullet as pb
import pybullet_data

from sparc_quad.robots import ROBOTS_DIR
from sparc_quad.sim.imu import ImuConfig
from sparc_quad.sim.quadruped_urdf import DEFAULT_HOST, robot_paths
from spine_module import params as P


@dataclass(frozen=True)
class WorldConfig:
    host: str = DEFAULT_HOST
    dt_s: float = P.CONTROL_PERIOD_S  # 1 kHz
    slope_rad: float = 0.0  # ground rises along +x when positive (uphill)
    friction: float = 1.0  # foot-ground Coulomb coefficient
    seed: int = 0
    imu: ImuConfig = field(default_factory=ImuConfig)
    stand_height_m: float = 0.22  # hip-to-foot-centre height of the initial stance
    solver_iterations: int = 50
    mass_scale: float = 1.0  # every link's mass and inertia times this (study seeds: +-5 %)
    init_pitch_rad: float = 0.0  # initial body pitch added to the ground's (positive nose down)
    init_vx_m_s: float = 0.0  # initial forward velocity of the whole robot
    lock_spine: bool = False  # rigid spine: q2..q4 locked at the equilibrium arch by fixed constraints
    gravity_m_s2: float = P.GRAVITY_M_S2


@dataclass
class EstimatorOutput:
    q1: float
    dq1: float
    ddq1: float


class Estimator:
    """Torso estimator emulation: truth -> noise, bias, delay, a first-order filter on q̈1. Seeded."""

    NOISE_BLOCK = 1000  # steps of noise drawn at once

    def __init__(self, cfg: ImuConfig, dt: float, rng: np.random.Generator):
        self.cfg, self.dt, self.rng = cfg, dt, rng
        self._buf: collections.deque = collections.deque(maxlen=max(1, cfg.delay_steps + 1))
        self._prev_dq1: float | None = None
        self._acc = 0.0
        self._noise: list[list[float]] = []
        self._k = 0
        self._alpha = (
            1.0 - math.exp(-2 * math.pi * cfg.accel_filter_hz * dt) if cfg.accel_filter_hz > 0 else 1.0
        )

    def update(self, q1: float, dq1: float) -> EstimatorOutput:
        c = self.cfg
        k = self._k
        if k == len(self._noise):  # draw ahead in blocks: the same stream as three draws per step
            self._noise = self.rng.standard_normal((self.NOISE_BLOCK, 3)).tolist()
            k = 0
        n = self._noise[k]
        self._k = k + 1
        mq = q1 + c.q1_bias_rad + c.q1_noise_rad * n[0]
        mdq = dq1 + c.dq1_bias_rad_s + c.dq1_noise_rad_s * n[1]
        raw_acc = 0.0 if self._prev_dq1 is None else (dq1 - self._prev_dq1) / self.dt
        self._prev_dq1 = dq1
        self._acc += self._alpha * (raw_acc - self._acc)
        self._buf.append(EstimatorOutput(mq, mdq, self._acc + c.ddq1_noise_rad_s2 * n[2]))
        return self._buf[0]


def _pitch_of(quat) -> float:
    """Pitch about +y (positive nose down) of a body whose x axis is its forward direction."""
    x, y, z, w = quat
    fx = 1 - 2 * (y * y + z * z)  # R[0,0]
    fz = 2 * (x * z - w * y)  # R[2,0]
    return math.atan2(-fz, fx)


def _quat_about_y(angle: float) -> tuple[float, float, float, float]:
    return (0.0, math.sin(0.5 * angle), 0.0, math.cos(0.5 * angle))


@dataclass
class LegState:
    key: str
    hfe: float
    kfe: float
    dhfe: float
    dkfe: float
    haa: float
    dhaa: float
    contact: bool


class QuadrupedWorld:
    """One pybullet world with the spined quadruped standing on its four feet at t = 0."""

    def __init__(self, cfg: WorldConfig | None = None, robots_dir: Path = ROBOTS_DIR):
        self.cfg = cfg = cfg or WorldConfig()
        urdf_path, meta_path = robot_paths(robots_dir, cfg.host)
        self.meta = json.loads(meta_path.read_text())
        self.rng = np.random.default_rng(cfg.seed)
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
            _quat_about_y(-cfg.slope_rad),
            physicsClientId=c,
        )
        pb.changeDynamics(self.ground, -1, lateralFriction=cfg.friction, physicsClientId=c)
        self.robot = pb.loadURDF(
            str(urdf_path), [0, 0, 1.0], flags=pb.URDF_USE_INERTIA_FROM_FILE, physicsClientId=c
        )
        self.joint_index: dict[str, int] = {}
        self.link_index: dict[str, int] = {self.meta["base_link"]: -1}
        for i in range(pb.getNumJoints(self.robot, physicsClientId=c)):
            info = pb.getJointInfo(self.robot, i, physicsClientId=c)
            self.link_index[info[12].decode()] = i
            if info[2] == pb.JOINT_REVOLUTE:
                self.joint_index[info[1].decode()] = i
        self.movable = sorted(self.joint_index.values())
        # joint index -> its place in jq, jdq and the torques
        self.pos_in_movable = {j: k for k, j in enumerate(self.movable)}
        # Default velocity motors off: every joint is torque controlled.
        pb.setJointMotorControlArray(
            self.robot, self.movable, pb.VELOCITY_CONTROL, forces=[0.0] * len(self.movable), physicsClientId=c
        )
        for link in range(-1, pb.getNumJoints(self.robot, physicsClientId=c)):
            pb.changeDynamics(
                self.robot, link, linearDamping=0.0, angularDamping=0.0, jointDamping=0.0, physicsClientId=c
            )
            if cfg.mass_scale != 1.0:
                info = pb.getDynamicsInfo(self.robot, link, physicsClientId=c)
                pb.changeDynamics(self.robot, link, mass=info[0] * cfg.mass_scale,
                                  localInertiaDiagonal=[v * cfg.mass_scale for v in info[2]],
                                  physicsClientId=c)
        self.legs = self.meta["legs"]
        self.foot_links = {self.link_index[v["foot_link"]]: k for k, v in self.legs.items()}
        parent = {
            i: pb.getJointInfo(self.robot, i, physicsClientId=c)[16]
            for i in range(pb.getNumJoints(self.robot, physicsClientId=c))
        }
        leg_roots = {self.joint_index[v["haa"]] for v in self.legs.values()}
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
        self.spine_idx = [self.joint_index[n] for n in self.meta["spine_joints"]]
        self._spine_pos = tuple(self.pos_in_movable[j] for j in self.spine_idx)  # q2, q3, q4 in jq
        self.leg_idx = {
            k: (self.joint_index[v["haa"]], self.joint_index[v["hfe"]], self.joint_index[v["kfe"]])
            for k, v in self.legs.items()
        }
        # set_torques lists spine then legs (HAA, HFE, KFE each) then a 0 for any other joint;
        # _tau_order[p] = where in that list movable joint p is
        self._leg_keys = tuple(self.leg_idx)
        listed = [*self.spine_idx, *(j for k in self._leg_keys for j in self.leg_idx[k])]
        self._tau_order = [listed.index(j) if j in listed else len(listed) for j in self.movable]
        self._reorder = operator.itemgetter(*self._tau_order)
        dyn = pb.getDynamicsInfo(self.robot, -1, physicsClientId=c)
        self._base_inertial_pos = np.array(dyn[3])
        self._base_inertial_xyz = tuple(float(v) for v in dyn[3])  # plain floats for the per-step read
        self.total_mass = sum(
            pb.getDynamicsInfo(self.robot, i, physicsClientId=c)[0]
            for i in range(-1, pb.getNumJoints(self.robot, physicsClientId=c))
        )
        self.estimator = Estimator(cfg.imu, cfg.dt_s, self.rng)
        self.t = 0.0
        self.steps = 0
        self._tau = [0.0] * len(self.movable)
        self.physics_wall_s = 0.0  # wall time spent inside stepSimulation (for the co-simulation bench)
        self.reset_stand(pitch_rad=-cfg.slope_rad + cfg.init_pitch_rad)
        if cfg.init_vx_m_s:
            pb.resetBaseVelocity(self.robot, [cfg.init_vx_m_s, 0, 0], [0, 0, 0], physicsClientId=c)
            self.read()
        self.spine_locks = self._lock_spine() if cfg.lock_spine else []

    def _lock_spine(self) -> list[int]:
        """Fixed constraints between consecutive spine links at their present relative poses: q2..q4 locked
        (a rigid spine, not a stiff controller). Returns the constraint ids."""
        c = self.client

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
    def leg_ik(self, key: str, x: float, z: float) -> tuple[float, float]:
        """Planar IK: HFE, KFE putting the foot centre at (x, z) from the hip in the body frame."""
        leg = self.legs[key]
        l1, l2, sgn = leg["thigh_m"], leg["shank_m"], leg["knee_sign"]
        r2 = x * x + z * z
        ck = max(-1.0, min(1.0, (r2 - l1 * l1 - l2 * l2) / (2 * l1 * l2)))
        k = sgn * math.acos(ck)
        # foot = -l1 (sin h, cos h) - l2 (sin(h+k), cos(h+k)); solve for h
        a = l1 + l2 * math.cos(k)
        b = l2 * math.sin(k)
        # x = -(a sin h + b cos h), z = -(a cos h - b sin h)
        h = math.atan2(-x, -z) - math.atan2(b, a)
        return h, k

    def reset_stand(self, pitch_rad: float | None = None) -> None:
        """Place the robot on its feet, spine at equilibrium, body parallel to the ground, at rest."""
        c = self.client
        cfg = self.cfg
        pitch = -cfg.slope_rad if pitch_rad is None else pitch_rad
        h = cfg.stand_height_m
        r = self.meta["foot_radius_m"]
        q_eq = self.meta["q_equilibrium"]
        for name, q in zip(self.meta["spine_joints"], q_eq[1:], strict=True):
            pb.resetJointState(self.robot, self.joint_index[name], q, 0.0, physicsClientId=c)
        for key, (haa, hfe, kfe) in self.leg_idx.items():
            hq, kq = self.leg_ik(key, 0.0, -h)
            pb.resetJointState(self.robot, haa, 0.0, 0.0, physicsClientId=c)
            pb.resetJointState(self.robot, hfe, hq, 0.0, physicsClientId=c)
            pb.resetJointState(self.robot, kfe, kq, 0.0, physicsClientId=c)
        # hind body frame: hips at height h + r above the ground, measured along the ground normal
        quat = _quat_about_y(pitch)
        n = (math.sin(-cfg.slope_rad), 0.0, math.cos(-cfg.slope_rad))  # ground normal
        frame = np.array(n) * (h + r + 1e-3)
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

    def front_weight_share(self) -> float:
        """Fraction of the weight the front legs carry when standing (COM between the hip lines)."""
        hind = self.legs["HL"]["hip_x_m"]
        # front hips in the hind-body frame with the spine at its equilibrium arch
        front = self.legs["FL"]["hip_x_m"] + float(P.X_EQUILIBRIUM[0]) - self.meta["front_body_length_m"]
        x0 = self.base_pos[0]
        return (self.com_x() - x0 - hind) / (front - hind)

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
        self.q1 = _pitch_of(quat)
        self.dq1 = w[1]
        self.roll = math.atan2(rot[7], rot[8])
        self.yaw = math.atan2(rot[3], rot[0])
        js = pb.getJointStates(self.robot, self.movable, physicsClientId=c)
        self.jq = jq = [s[0] for s in js]
        self.jdq = jdq = [s[1] for s in js]
        a, b, d = self._spine_pos
        self.q_spine = [jq[a], jq[b], jq[d]]
        self.dq_spine = [jdq[a], jdq[b], jdq[d]]
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

    def leg_state(self, key: str) -> LegState:
        pim = self.pos_in_movable
        haa, hfe, kfe = self.leg_idx[key]
        return LegState(
            key,
            self.jq[pim[hfe]],
            self.jq[pim[kfe]],
            self.jdq[pim[hfe]],
            self.jdq[pim[kfe]],
            self.jq[pim[haa]],
            self.jdq[pim[haa]],
            self.contact_force[key] > 0.0,
        )

    def estimate(self) -> EstimatorOutput:
        """The emulated torso estimator's output for the current step (call once per step)."""
        return self.estimator.update(self.q1, self.dq1)

    # ---- actuation -----------------------------------------------------------------------------------
    def set_torques(self, spine_tau, leg_tau: dict[str, tuple[float, float, float]]) -> None:
        """Torques for this step: spine (q2, q3, q4) and per leg (HAA, HFE, KFE), N*m."""
        a, b, c = spine_tau  # pybullet converts each value to a double (as float() did)
        vals = [a, b, c]
        for key in self._leg_keys:
            ha, hf, kf = leg_tau[key]
            vals += (ha, hf, kf)
        vals.append(0.0)
        self._tau = self._reorder(vals)

    @property
    def applied_torques(self) -> list[float]:
        return self._tau

    def step(self) -> None:
        pb.setJointMotorControlArray(
            self.robot, self.movable, pb.TORQUE_CONTROL, forces=self._tau, physicsClientId=self.client
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

    def __enter__(self) -> QuadrupedWorld:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

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
