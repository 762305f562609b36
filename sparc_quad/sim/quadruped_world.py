"""The spined quadruped's world behind one small interface, whatever the physics engine: 1 kHz, torque
control on every joint, flat or sloped ground, and an emulation of the torso state estimator (q1 and its
rates from a simulated IMU on the hind body).

`make_world(cfg)` builds the world of `cfg.engine` ("pybullet" or "mujoco", sparc_quad.sim.engines) for
`cfg.host` (sparc_quad.sim.hosts). `QuadWorld` holds what every engine shares (the estimator, leg IK,
torque ordering, leg states); a backend fills the state attributes in `read()` and steps its engine.
Every random number comes from the world's own seeded generator; worlds can run side by side.

Conventions: world x forward (down the slope's rising direction), z up; pitch about +y, positive nose
down (the spine model's q1 convention). q1 is the hind body's pitch relative to gravity. Legs without
an abduction joint (the spined dog) read 0 for it and ignore its torque: `ABSENT` is its index.
"""

from __future__ import annotations

import collections
import json
import math
import operator
from abc import ABC, abstractmethod
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from sparc_quad.robots import ROBOTS_DIR
from sparc_quad.sim.bound_log import LEG_JOINTS, LEGS
from sparc_quad.sim.hosts import DEFAULT_HOST, host_files
from sparc_quad.sim.imu import ImuConfig
from spine_module import params as P


@dataclass(frozen=True)
class WorldConfig:
    host: str = DEFAULT_HOST
    engine: str = "pybullet"  # sparc_quad.sim.engines.ENGINES
    dt_s: float = P.CONTROL_PERIOD_S  # 1 kHz
    slope_rad: float = 0.0  # ground rises along +x when positive (uphill)
    friction: float = 1.0  # foot-ground Coulomb coefficient
    seed: int = 0
    imu: ImuConfig = field(default_factory=ImuConfig)
    stand_height_m: float = 0.22  # hip-to-foot-centre height of the initial stance
    solver_iterations: int = 50  # pybullet's; MuJoCo uses the spined dog's MJCF options
    mass_scale: float = 1.0  # every link's mass and inertia times this (study seeds: +-5 %)
    init_pitch_rad: float = 0.0  # initial body pitch added to the ground's (positive nose down)
    init_vx_m_s: float = 0.0  # initial forward velocity of the whole robot
    lock_spine: bool = False  # rigid spine: q2..q4 locked at the equilibrium arch by fixed constraints
    lock_spine_q_rad: tuple[float, float, float] | None = None  # where it is locked (None: the arch)
    # every hinge's viscous damping and dry friction (MuJoCo: dof damping, frictionloss; pybullet: joint
    # damping, a velocity motor of that force limit): the authors' later dog model has 0.1 and 0.1
    joint_damping_nm_s_rad: float = 0.0
    joint_friction_nm: float = 0.0
    leg_torque_limit_nm: float | None = None  # the leg motors' limit (None: the host's; 120 in that model)
    gravity_m_s2: float = P.GRAVITY_M_S2
    # what the torso estimate says of the base's linear motion (BASE_MOTIONS): "fixed", none (the spine
    # law's base joint has a fixed origin, the paper's law); "constant-twist", the base joint origin's
    # acceleration a = w x v (hind-body frame, m/s^2) of a body whose body-frame twist (v, w) is constant:
    # the assumption of the authors' law (zero spatial acceleration of their floating base); "authors-cvel",
    # the same a = w x v of the twist the authors' released code feeds that law: MuJoCo's `cvel` of the hind
    # body (w: its angular velocity, v: the velocity of the point at the whole robot's centre of mass moving
    # with the hind body, both in world axes) read as if it were the hind body's body-frame twist, one step
    # late as their code reads it (their reading, not a physically consistent body twist)
    base_motion: str = "fixed"


BASE_MOTIONS = ("fixed", "constant-twist", "authors-cvel")


@dataclass(slots=True)
class EstimatorOutput:
    q1: float
    dq1: float
    ddq1: float
    base_accel: tuple[float, float, float] | None = None  # m/s^2, hind-body frame; None: not estimated


def constant_twist_accel(twist, r=(0.0, 0.0, 0.0)) -> tuple[float, float, float]:
    """Linear acceleration (body frame, m/s^2) of the point `r` (m, body frame) of a body whose body-frame
    twist (vx, vy, vz, wx, wy, wz) of its frame origin (m/s, rad/s) is constant: zero spatial acceleration
    leaves the classical one, w x v_r with v_r = v + w x r."""
    vx, vy, vz, wx, wy, wz = twist
    rx, ry, rz = r
    if rx or ry or rz:
        vx, vy, vz = vx + wy * rz - wz * ry, vy + wz * rx - wx * rz, vz + wx * ry - wy * rx
    return (wy * vz - wz * vy, wz * vx - wx * vz, wx * vy - wy * vx)


def twist_lag_problem(base_motion: str, twist_lag_steps: int, delay_steps: int) -> str | None:
    """Why an estimator cannot file a twist `twist_lag_steps` old under an estimate `delay_steps` late
    (MuJoCo's `cvel` after mj_step is the state before the step), or None."""
    if twist_lag_steps > delay_steps:
        return (f"base_motion {base_motion!r} reads a twist {twist_lag_steps} step(s) late (MuJoCo's cvel "
                f"lags qpos by a step after mj_step): it needs the estimator's delay_steps >= "
                f"{twist_lag_steps}, got {delay_steps}")
    return None


class Estimator:
    """Torso estimator emulation: truth -> noise, bias, delay, a first-order filter on q̈1. Seeded.

    `base_motion` "constant-twist" adds the base joint origin's acceleration under a constant body twist
    (`constant_twist_accel` of the true twist given to `update`, at `base_point_m` in the hind-body frame;
    noise-free, delayed with the rest); "authors-cvel" the same formula of the authors' twist
    (`QuadWorld.authors_twist`: the hind body's `cvel`, world axes, read as body-frame); "fixed" leaves it out
    (`base_accel` None).

    `twist_lag_steps` (0 or 1): how many steps old the twist given to `update` already is. MuJoCo's `cvel`
    after `mj_step` is the state before the step (one step behind `qpos`): given the step-k update, it is
    state k - 1's, and the estimator files it under state k - 1 (and, at the first update, under state 0,
    whose own it is after `mj_forward`), so that the estimate's base acceleration comes with the estimate's
    delay like everything else. It needs `delay_steps` >= the lag."""

    NOISE_BLOCK = 1000  # steps of noise drawn at once

    def __init__(self, cfg: ImuConfig, dt: float, rng: np.random.Generator, base_motion: str = "fixed",
                 base_point_m: tuple[float, float, float] = (0.0, 0.0, 0.0), twist_lag_steps: int = 0):
        if base_motion not in BASE_MOTIONS:
            raise ValueError(f"base_motion must be one of {', '.join(BASE_MOTIONS)}, got {base_motion!r}")
        if twist_lag_steps not in (0, 1):
            raise ValueError(f"twist_lag_steps must be 0 or 1, got {twist_lag_steps!r}")
        problem = twist_lag_problem(base_motion, twist_lag_steps, cfg.delay_steps)
        if problem is not None:
            raise ValueError(problem)
        self.base_motion = base_motion
        self.needs_twist = base_motion != "fixed"
        self.uses_authors_twist = base_motion == "authors-cvel"  # given `authors_twist`, not `base_twist`
        self._lagged = twist_lag_steps == 1
        self.base_point_m = tuple(float(v) for v in base_point_m)
        self.cfg, self.dt, self.rng = cfg, dt, rng
        self._buf: collections.deque = collections.deque(maxlen=max(1, cfg.delay_steps + 1))
        self._prev_dq1: float | None = None
        self._acc = 0.0
        self._noise: list[list[float]] = []
        self._k = 0
        self._alpha = (
            1.0 - math.exp(-2 * math.pi * cfg.accel_filter_hz * dt) if cfg.accel_filter_hz > 0 else 1.0
        )

    @property
    def delay_line_length(self) -> int:
        """How many estimates the delay line holds: delay_steps + 1 (at least 1)."""
        return self._buf.maxlen

    @property
    def accel_filter_alpha(self) -> float:
        """The first-order q̈1 filter's gain per step (1: no filter)."""
        return self._alpha

    def draw_noise(self) -> np.ndarray:
        """The next block of standard normals, a row of three per step: drawn ahead in blocks, the same
        stream as three draws per step."""
        return self.rng.standard_normal((self.NOISE_BLOCK, 3))

    def save(self) -> tuple:
        """Where the estimator stands (the compiled step carries it on and `restore`s it): the noise block
        (list of rows), the next row, the previous true dq1 (None before the first update), the filtered
        q̈1, and the delay line's outputs as (q1, dq1, ddq1), oldest first."""
        return (self._noise, self._k, self._prev_dq1, self._acc,
                [(e.q1, e.dq1, e.ddq1) for e in self._buf])

    def restore(self, noise: list, k: int, prev_dq1: float | None, acc: float, line) -> None:
        """Take up the state `save` gives ("fixed" base motion: the delay line's entries have no base
        acceleration)."""
        self._noise, self._k, self._prev_dq1, self._acc = noise, k, prev_dq1, acc
        self._buf.clear()
        self._buf.extend(EstimatorOutput(q, dq, ddq) for q, dq, ddq in line)

    def update(self, q1: float, dq1: float, twist=None) -> EstimatorOutput:
        """This step's estimate from the true q1, dq1 and (constant-twist) the true body twist of the
        hind-body frame origin (vx, vy, vz m/s, wx, wy, wz rad/s, hind-body frame) or (authors-cvel) the
        authors' twist (`QuadWorld.authors_twist`, `twist_lag_steps` old)."""
        c = self.cfg
        k = self._k
        if k == len(self._noise):
            self._noise = self.draw_noise().tolist()
            k = 0
        n = self._noise[k]
        self._k = k + 1
        mq = q1 + c.q1_bias_rad + c.q1_noise_rad * n[0]
        mdq = dq1 + c.dq1_bias_rad_s + c.dq1_noise_rad_s * n[1]
        raw_acc = 0.0 if self._prev_dq1 is None else (dq1 - self._prev_dq1) / self.dt
        self._prev_dq1 = dq1
        self._acc += self._alpha * (raw_acc - self._acc)
        acc = constant_twist_accel(twist, self.base_point_m) if self.needs_twist else None
        buf = self._buf
        if self._lagged and buf:  # the twist is the previous state's: it completes that state's entry
            buf[-1].base_accel = acc  # (returned only from the next update on: delay_steps >= 1)
        buf.append(EstimatorOutput(mq, mdq, self._acc + c.ddq1_noise_rad_s2 * n[2], acc))
        return buf[0]


def pitch_of(quat) -> float:
    """Pitch about +y (positive nose down) of a body whose x axis is its forward direction (quat xyzw)."""
    x, y, z, w = quat
    fx = 1 - 2 * (y * y + z * z)  # R[0,0]
    fz = 2 * (x * z - w * y)  # R[2,0]
    return math.atan2(-fz, fx)


def quat_about_y(angle: float) -> tuple[float, float, float, float]:
    """Quaternion (x, y, z, w) of a rotation by `angle` about +y."""
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


# what `QuadWorld.step_chunk` keeps per step (`held_rows`), named as the bound log's columns (bound_log)
HELD_STATE = ("x", "y", "z", "q2", "q3", "q4", "dq2", "dq3", "dq4",
              *(f"contact_{leg}" for leg in LEGS), *(f"dq_{j}" for j in LEG_JOINTS))

ABSENT = -1  # the joint index of a leg joint the robot does not have (the spined dog's abduction)


class QuadWorld(ABC):
    """One world with the spined quadruped standing on its four feet at t = 0.

    State a backend's `read()` sets (world frame, SI): base_pos, base_vel (hind-body frame origin),
    base_quat (x, y, z, w), base_rot (row-major 3x3 as 9 floats), base_omega (world axes), q1, dq1, roll,
    yaw, jq, jdq (per `movable` joint; an ABSENT joint reads 0), q_spine, dq_spine, contact_force (leg ->
    normal force, N), other_contact, body_contact."""

    engine: str = ""

    def __init__(self, cfg: WorldConfig | None = None, robots_dir: Path = ROBOTS_DIR):
        """The shared part: the host's files (`self.files`) and metadata, the estimator, the clock."""
        self.cfg = cfg = cfg or WorldConfig()
        self.files = host_files(cfg.host, robots_dir)
        self.meta = meta = load_meta(self.files.meta)
        self.legs = meta["legs"]
        self.rng = np.random.default_rng(cfg.seed)
        # the spine model's base joint (q1) sits at the hind-body frame origin in every host
        # (quadruped_urdf's layout, the spined dog's hind_body frame): `spine_base_in_hind_m` otherwise
        self.estimator = Estimator(cfg.imu, cfg.dt_s, self.rng, cfg.base_motion,
                                   tuple(meta.get("spine_base_in_hind_m", (0.0, 0.0, 0.0))),
                                   self.cvel_lag_steps if cfg.base_motion == "authors-cvel" else 0)
        self.t = 0.0
        self.steps = 0
        self.physics_wall_s = 0.0  # wall time spent inside the engine's step (benches)
        self.total_mass = 0.0

    def _index_joints(self, joint_index: dict[str, int]) -> None:
        """Index the actuated joints: `joint_index` maps each joint name to the backend's joint id."""
        self.joint_index = dict(joint_index)
        absent = any(v["haa"] is None for v in self.legs.values())
        self.movable = sorted(self.joint_index.values()) + ([ABSENT] if absent else [])
        self.pos_in_movable = {j: k for k, j in enumerate(self.movable)}  # joint id -> its place in jq
        self.n_engine_joints = len(self.joint_index)
        self.spine_idx = [self.joint_index[n] for n in self.meta["spine_joints"]]
        self._spine_pos = tuple(self.pos_in_movable[j] for j in self.spine_idx)  # q2, q3, q4 in jq
        self._spine_of = operator.itemgetter(*self._spine_pos)  # jq -> (q2, q3, q4)
        self.leg_idx = {
            k: (ABSENT if v["haa"] is None else self.joint_index[v["haa"]], self.joint_index[v["hfe"]],
                self.joint_index[v["kfe"]])
            for k, v in self.legs.items()
        }
        self._leg_slots = {k: tuple(self.pos_in_movable[j] for j in v) for k, v in self.leg_idx.items()}
        # set_torques lists spine then legs (HAA, HFE, KFE each) then a 0 for any other joint;
        # _tau_order[p] = where in that list movable joint p is
        self._leg_keys = tuple(self.leg_idx)
        listed = [*self.spine_idx, *(j for k in self._leg_keys for j in self.leg_idx[k])]
        self._tau_order = [listed.index(j) if j in listed and j != ABSENT else len(listed)
                           for j in self.movable]
        self._reorder = operator.itemgetter(*self._tau_order)
        self._tau = [0.0] * len(self.movable)

    @property
    def leg_torque_limit_nm(self) -> float:
        """The leg motors' torque limit, N*m: the world's override or the host's."""
        lim = self.cfg.leg_torque_limit_nm
        return float(self.meta["leg_torque_limit_nm"] if lim is None else lim)

    # ---- set-up ---------------------------------------------------------------------------------------
    def leg_ik(self, key: str, x: float, z: float) -> tuple[float, float]:
        """Planar IK: HFE, KFE putting the foot centre at (x, z) from the hip in the body frame."""
        return planar_leg_ik(*self.leg_links(key), x, z)

    def leg_links(self, key: str) -> tuple[float, float, float]:
        """(thigh m, shank m, knee sign) of leg `key`: `planar_leg_ik`'s constants."""
        leg = self.legs[key]
        return leg["thigh_m"], leg["shank_m"], leg["knee_sign"]

    def leg_joint_slots(self, key: str) -> tuple[int, int, int]:
        """Where leg `key`'s HAA, HFE, KFE are in `jq` / `jdq` (an absent joint: the trailing 0)."""
        return self._leg_slots[key]

    def set_start(self, q_spine: list[float] | None, legs: dict[str, tuple[float, float]],
                  frame_height_m: float | None) -> None:
        """Start from this pose instead of the stand (a gait that starts on its trajectory): spine q2..q4
        (None: the equilibrium arch), each leg's (HFE, KFE), the hind-body frame's height (None: the
        stand's); then reset to it."""
        self._start = (q_spine, dict(legs), frame_height_m)
        self.reset_stand()

    def stand_pose(self) -> tuple[list[float], dict[str, tuple[float, float]]]:
        """Spine q2..q4 at the equilibrium arch and each leg's (HFE, KFE) with its foot `stand_height_m`
        straight below its hip (or the pose given to `set_start`)."""
        q_eq = self.meta["q_equilibrium"]
        start = getattr(self, "_start", None)
        if start is not None:
            return list(q_eq[1:]) if start[0] is None else list(start[0]), dict(start[1])
        legs = {key: self.leg_ik(key, 0.0, -self.cfg.stand_height_m) for key in self.leg_idx}
        return list(q_eq[1:]), legs

    def stand_frame_height_m(self) -> float:
        """Height of the hind-body frame above the ground (along its normal) in the initial stance."""
        start = getattr(self, "_start", None)
        if start is not None and start[2] is not None:
            return start[2]
        return self.cfg.stand_height_m + self.meta["foot_radius_m"] + 1e-3

    @abstractmethod
    def reset_stand(self, pitch_rad: float | None = None) -> None:
        """Place the robot on its feet, spine at equilibrium, body parallel to the ground, at rest."""

    @abstractmethod
    def com_x(self) -> float:
        """World x of the whole robot's centre of mass."""

    def front_weight_share(self) -> float:
        """Fraction of the weight the front legs carry when standing (COM between the hip lines)."""
        hind = self.legs["HL"]["hip_x_m"]
        # front hips in the hind-body frame with the spine at its equilibrium arch
        front = self.meta.get("front_hip_x_in_hind_m")
        if front is None:
            front = self.legs["FL"]["hip_x_m"] + float(P.X_EQUILIBRIUM[0]) - self.meta["front_body_length_m"]
        x0 = self.base_pos[0]
        return (self.com_x() - x0 - hind) / (front - hind)

    # ---- state ---------------------------------------------------------------------------------------
    @abstractmethod
    def read(self) -> None:
        """Refresh the true state (sim side) from the engine."""

    def leg_state(self, key: str) -> LegState:
        haa, hfe, kfe = self.leg_joint_slots(key)
        jq, jdq = self.jq, self.jdq
        return LegState(key, jq[hfe], jq[kfe], jdq[hfe], jdq[kfe], jq[haa], jdq[haa],
                        self.contact_force[key] > 0.0)

    def leg_rates(self) -> tuple[float, ...]:
        """The 12 leg joint rates HL, HR, FL, FR x (HAA, HFE, KFE), rad/s (0 for an absent joint)."""
        if not hasattr(self, "_leg_dq"):
            pim = self.pos_in_movable
            self._leg_dq = operator.itemgetter(*(pim[j] for k in ("HL", "HR", "FL", "FR")
                                                 for j in self.leg_idx[k]))
        return self._leg_dq(self.jdq)

    def estimate(self) -> EstimatorOutput:
        """The emulated torso estimator's output for the current step (call once per step)."""
        est = self.estimator
        if not est.needs_twist:
            return est.update(self.q1, self.dq1)
        twist = self.authors_twist() if est.uses_authors_twist else self.base_twist()
        return est.update(self.q1, self.dq1, twist)

    def base_twist(self) -> tuple[float, ...]:
        """The hind-body frame origin's twist in the hind-body frame: (vx, vy, vz) m/s, (wx, wy, wz)
        rad/s, from base_vel, base_omega (world axes) and base_rot."""
        r = self.base_rot
        vx, vy, vz = self.base_vel
        wx, wy, wz = self.base_omega
        return (r[0] * vx + r[3] * vy + r[6] * vz, r[1] * vx + r[4] * vy + r[7] * vz,
                r[2] * vx + r[5] * vy + r[8] * vz, r[0] * wx + r[3] * wy + r[6] * wz,
                r[1] * wx + r[4] * wy + r[7] * wz, r[2] * wx + r[5] * wy + r[8] * wz)

    # how many steps old `authors_twist` is when read (MuJoCo: 1, its cvel after mj_step)
    cvel_lag_steps = 0

    def authors_twist(self) -> tuple[float, ...]:
        """The twist the SPARC authors' released code feeds their spine law as the hind body's body-frame
        twist: MuJoCo's `cvel` of the hind body, (v; w) = the velocity of the point at the whole robot's
        centre of mass moving rigidly with the hind body and the hind body's angular velocity, both in
        world axes (vx, vy, vz m/s, wx, wy, wz rad/s); `cvel_lag_steps` old."""
        raise NotImplementedError(f"the {self.engine} world has no authors' twist")

    def authors_body_states(self) -> tuple:
        """What the SPARC authors' Raibert bound (gait C) reads of the trunk, as MuJoCo's `xpos`, `xmat` and
        `cvel` hold it (`cvel_lag_steps` old): (hind-body origin (3,) m, its rotation (9, row-major), the
        `cvel` linear part of the hind body (3,) m/s and its angular velocity (3,) rad/s, the front body's
        rotation (9,), the front body's `cvel` linear part (3,) m/s); world axes. A body's `cvel` linear part
        is the velocity of the point at the whole robot's centre of mass moving rigidly with that body."""
        raise NotImplementedError(f"the {self.engine} world has no authors' body states")

    # ---- actuation -----------------------------------------------------------------------------------
    def set_torques(self, spine_tau, leg_tau: dict[str, tuple[float, float, float]]) -> None:
        """Torques for this step: spine (q2, q3, q4) and per leg (HAA, HFE, KFE), N*m."""
        a, b, c = spine_tau  # the engines convert each value to a double (as float() did)
        vals = [a, b, c]
        for key in self._leg_keys:
            ha, hf, kf = leg_tau[key]
            vals += (ha, hf, kf)
        vals.append(0.0)
        self._tau = self._reorder(vals)

    def torque_sources(self) -> list[tuple[str, int] | None]:
        """Where `set_torques` takes each `movable` joint's torque from: ("spine", k) for q(2+k), (leg, r)
        for a leg's HAA, HFE, KFE (r = 0, 1, 2), None for a joint it sets to 0."""
        keys = self._leg_keys
        n_listed = 3 + 3 * len(keys)
        return [("spine", j) if j < 3 else (keys[(j - 3) // 3], (j - 3) % 3) if j < n_listed else None
                for j in self._tau_order]

    def set_joint_torques(self, tau: list[float]) -> None:
        """Torques for this step already in `movable` order, N*m (what `set_torques` computes)."""
        self._tau = tau

    @property
    def applied_torques(self) -> list[float]:
        return self._tau

    @abstractmethod
    def step(self) -> None:
        """Apply the torques, advance one dt, refresh the state."""

    # ---- held steps (a controller holding its output between calls: sparc_quad.bound.held_loop) ---
    # Only a world that can take back part of a chunk (`can_rewind`) runs them; `run_bound` steps every
    # other world in full, so these are declared here and implemented by such a world (MuJoCo).
    can_rewind = False

    def start_held(self, n_rows: int) -> None:
        """Room for the states before steps 0 .. n_rows - 1 (`step_chunk`; `held_rows`)."""
        raise NotImplementedError(f"the {self.engine} world does not step held chunks")

    def step_chunk(self, k: int, row: int) -> list[tuple]:
        """Advance k steps with the torques last set (`set_torques`), keeping each new state as the state
        before steps row + 1 .. row + k; per new state (t, q1, dq1, roll, yaw, q_spine, dq_spine,
        body_contact, twist), as `read` gives them (twist: `base_twist`'s, or `authors_twist`'s under
        "authors-cvel", as either reads at that state; None unless the estimator needs it). The state
        attributes are the last state's, read in full."""
        raise NotImplementedError(f"the {self.engine} world does not step held chunks")

    def rewind(self, r: int) -> None:
        """Back to the last chunk's r-th new state (1 <= r < k), read in full."""
        raise NotImplementedError(f"the {self.engine} world does not rewind")

    def held_rows(self, rows: np.ndarray) -> np.ndarray:
        """The HELD_STATE values of the kept states before steps `rows`."""
        raise NotImplementedError(f"the {self.engine} world does not step held chunks")

    @abstractmethod
    def close(self) -> None: ...

    def __enter__(self) -> QuadWorld:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def render(self, width: int = 480, height: int = 320) -> np.ndarray:
        """An RGB frame, camera following the robot."""
        raise NotImplementedError(f"the {self.engine} world does not render")


def planar_leg_ik(l1: float, l2: float, sgn: float, x: float, z: float) -> tuple[float, float]:
    """HFE, KFE of a two-link leg (thigh `l1`, shank `l2` m, knee bending to `sgn`) putting the foot centre
    at (x, z) m from the hip in the body frame."""
    r2 = x * x + z * z
    ck = max(-1.0, min(1.0, (r2 - l1 * l1 - l2 * l2) / (2 * l1 * l2)))
    k = sgn * math.acos(ck)
    # foot = -l1 (sin h, cos h) - l2 (sin(h+k), cos(h+k)); solve for h
    a = l1 + l2 * math.cos(k)
    b = l2 * math.sin(k)
    # x = -(a sin h + b cos h), z = -(a cos h - b sin h)
    h = math.atan2(-x, -z) - math.atan2(b, a)
    return h, k


def load_meta(path: Path) -> dict:
    return json.loads(path.read_text())


def make_world(cfg: WorldConfig | None = None, robots_dir: Path = ROBOTS_DIR) -> QuadWorld:
    """The world of `cfg.engine` for `cfg.host` (the engine's module is imported here, lazily)."""
    from sparc_quad.sim.engines import world_class

    cfg = cfg or WorldConfig()
    return world_class(cfg.engine)(cfg, robots_dir)


def QuadrupedWorld(cfg: WorldConfig | None = None, robots_dir: Path = ROBOTS_DIR) -> QuadWorld:
    """The world of `cfg.engine` (pybullet by default): the name the callers of the pybullet-only world
    used."""
    return make_world(cfg, robots_dir)
