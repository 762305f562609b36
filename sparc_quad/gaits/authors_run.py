"""Gait A as the SPARC authors run it on their spined dog: the spine side of their run (their gains,
schedule, clock, spine model, start pose and estimator). `sparc_quad.scenario` makes their whole run the
default of `gait = "sine"` on `host = "spined-dog"` from these.

Source: github.com/YueWang996/sparc, commit d9639f5, `mujoco_simulation/main_robot.py` (the schedule) and
`spine_impedance_controller.py` (the law's model: `asset/spined_dog_spine_dyn.urdf`, the hind body, three
spine joints and the front body, no legs); MIT, Copyright (c) 2026 YueWang996.

Their spine: Kp (k_x, 2000, 15) throughout, Kd (15, 5, 1.5) and x_d 0.273 m until 4 s, then Kd (8, 5, 0.5)
and x_d 0.268 m, computed at each call of their control loop (`ControlClock`, 5 ms rule), h and M from the
spine-only model. Here the project's impedance controller (spine_module.control) renders that schedule
(`SpineSchedule` + `ScheduledDrive`, gain and target changes the node's command accepts) on a
`SpineModel` built from the dog's own numbers (`spine_params`): hind lever 0.1068 m, links 0.1175 m, the
front body's frame (their task point) as the end effector, 2.044 kg front body without its legs, no rotor
inertia. What still differs from their law is the law (docs/bounding/authors-gait-a.md, "What differs from
their spine law").
"""

from __future__ import annotations

import math

from sparc_quad.sim.imu import ImuConfig
from sparc_quad.sim.spine_drive import SpineGains, SpineSchedule
from spine_module import params as P

AUTHORS_K_Z_N_M = 2000.0
AUTHORS_K_THETA_NM_RAD = 15.0
AUTHORS_CONTROL_HZ = 200.0  # their nominal rate; the 5 ms rule on a float clock gives ~182 Hz
JOINT_RANGE_RAD = 10.0  # their hinges' range
START_SPINE_Q_RAD = (-0.6, 1.2, -0.6)  # main_robot.py: the spine joints at t = 0
# the estimator the comparison with their run uses: no noise, one step late (their base pose is MuJoCo's
# xquat, which mj_step leaves one step behind qpos)
EXACT_IMU = ImuConfig(q1_noise_rad=0.0, dq1_noise_rad_s=0.0, ddq1_noise_rad_s2=0.0, delay_steps=1)
# their law's h is a floating-base RNEA of the spine chain at the hind body's twist with zero (body-frame,
# spatial) base acceleration: a body moving at a constant body twist (v, w), whose origin accelerates at
# w x v. Their code feeds it MuJoCo's `cvel` of the hind body, read one step late: w the hind body's angular
# velocity, v the velocity of the point at the whole robot's centre of mass moving with the hind body, both
# in world axes, read as if body-frame. The estimator gives the spine law that a = w x v ("authors-cvel":
# their reading, not a physically consistent body twist); "constant-twist" is the same law fed the hind
# body's true body twist, "fixed" the paper's law (WorldConfig.base_motion; docs/bounding/authors-gait-a.md,
# "Base motion")
BASE_MOTION = "authors-cvel"


def spine_params(end_effector_ahead_m: float = 0.0) -> P.SpineParams:
    """The spined dog's spine as the project's spine model sees it (planar chain about y: the y offsets of
    joints and centres of mass do not enter; the front body's 2.2 mm COM height and the first spine
    joint's 1 mm height are not representable and are left out; the latter shifts task z, see
    `task_z_offset_m`). The task point is the front body's frame, or `end_effector_ahead_m` ahead of it
    along its x (gait C's `spine_end_effector`, 0.107 m)."""
    from sparc_quad.sim import spined_dog as D

    def link(name: str, length_m: float) -> P.LinkParams:
        b = D.BY_NAME[name]
        return P.LinkParams(name, b.mass_kg, length_m, b.inertia_kg_m2, b.com_m[0])

    hs, fs, fb = (D.BY_NAME[n] for n in ("hind_spine", "front_spine", "front_body"))
    links = (link("hind_body", hs.pos_m[0]), link("hind_spine", fs.pos_m[0]),
             link("front_spine", fb.pos_m[0]), link("front_body", end_effector_ahead_m))
    lower = {"q1": -math.pi, **{q: -JOINT_RANGE_RAD for q in P.ACTUATED_JOINTS}}
    upper = {"q1": math.pi, **{q: JOINT_RANGE_RAD for q in P.ACTUATED_JOINTS}}
    return P.SpineParams(links=links, armature_kg_m2=0.0, torque_limit_nm=D.MOTOR_LIMIT_NM,
                         velocity_limit_rad_s=D.VELOCITY_LIMIT_RAD_S, lower_rad=lower, upper_rad=upper)


def task_z_offset_m() -> float:
    """Their task z (front-body frame in the hind-body frame) minus the model's: the first spine joint
    sits this high above the hind-body frame."""
    from sparc_quad.sim import spined_dog as D

    return D.BY_NAME["hind_spine"].pos_m[2]


def schedule() -> SpineSchedule:
    """Their schedule in the model's frame (their z_d = 0 is the model's -`task_z_offset_m`)."""
    return SpineSchedule(k0=None, z_d_m=-task_z_offset_m())


def gains(k_x_n_m: float) -> SpineGains:
    """The run's gains (after the switch): Kp (k_x, 2000, 15), Kd (8, 5, 0.5)."""
    return SpineGains(k=(k_x_n_m, AUTHORS_K_Z_N_M, AUTHORS_K_THETA_NM_RAD), d=tuple(P.AUTHORS_SPINE_D_RUN))


def node_config():
    """The spine node for their run (`bound --spine-path node`): no soft start (their controller has full
    gains from its first call) and the dog's joint range (the SPARC module's limits would damp the dog's
    spine, whose joints range over +-10 rad)."""
    import numpy as np

    from spine_module.node import NodeConfig
    from spine_module.safety import SafetyConfig

    sp = spine_params()
    lower = np.array([sp.lower_rad[q] for q in P.ACTUATED_JOINTS])
    upper = np.array([sp.upper_rad[q] for q in P.ACTUATED_JOINTS])
    return NodeConfig(safety=SafetyConfig(soft_start_s=0.0, lower=lower, upper=upper))


# Gait C (their speed-commanded Raibert bound: main_robot_raibert.py and dog_controller_raibert.py at
# 9aee563, spined_dog_spine_dyn.urdf at a7fca48): the spine law regulates `spine_end_effector`,
# 0.107249862 m ahead of the front body's frame, to x_d (0.367 m, 0.02 m, -0.3 rad) with Kp (2400, 3000, 15)
# and Kd (0, 30, 1) from its first call, at the legs' control clock (2 ms rule, ~408 Hz)
RAIBERT_EE_AHEAD_M = 0.107249862
RAIBERT_X_D = (0.367, 0.02, -0.3)
RAIBERT_K = (2400.0, 3000.0, 15.0)
RAIBERT_D = (0.0, 30.0, 1.0)
RAIBERT_CONTROL_HZ = 500.0  # their nominal rate; the 2 ms rule on a float clock gives ~408 Hz
RAIBERT_JOINT_DAMPING_NM_S_RAD = 0.1  # their model at 1c8013a: every joint
RAIBERT_JOINT_FRICTION_NM = 0.1
RAIBERT_LEG_LIMIT_NM = 120.0  # their model at 1c8013a: every motor's ctrlrange (the spine law clamps at 12)


def raibert_target(d: tuple[float, float, float]) -> SpineSchedule:
    """Gait C's constant target in the model's frame, with the run's damping `d` from the first call."""
    x, z, theta = RAIBERT_X_D
    return SpineSchedule(switch_s=0.0, k0=None, d0=tuple(d), x_d0_m=x, x_d1_m=x,
                         z_d_m=z - task_z_offset_m(), theta_d_rad=theta)
