"""A scenario's defaults filled in, and the simulator's `BoundConfig` it runs: the one translator.

`resolved(s)` fills every None key that acts in `s` with its robot's and gait's default, so the result says
exactly what runs (it is what `scenario.json` holds). `bound_config(s)` maps a scenario to the
simulator's configuration, with the seed's perturbation applied; the CLI, a study trial and Python all
call it, so a one-cell study and `sparc-quad bound` with the same keys run the same bound by construction.
"""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path
from typing import Any

from sparc_quad.bound.run import BoundConfig
from sparc_quad.gaits import authors_run as A
from sparc_quad.gaits.authors_raibert import LOCKED_SPINE_Q_RAD, AuthorsRaibertParams
from sparc_quad.gaits.bound import BoundParams
from sparc_quad.gaits.sine_bound import SineBoundParams
from sparc_quad.scenario.checks import check_runnable
from sparc_quad.scenario.model import KEYS, Scenario, ScenarioError
from sparc_quad.sim import spined_dog
from sparc_quad.sim.hosts import host_of
from sparc_quad.sim.imu import ImuConfig
from sparc_quad.sim.quadruped_world import WorldConfig
from sparc_quad.sim.seed_variation import perturbation
from sparc_quad.sim.spine_drive import SpineGains, SpineSchedule
from spine_module import params as P

_RAIBERT, _SINE, _GAIT_C = BoundParams(), SineBoundParams(), AuthorsRaibertParams()


def authors_run(s: Scenario) -> bool:
    """Gait A or C on the authors' own robot: their whole run (start, clock, spine target or schedule, spine
    model, estimator)."""
    on_dog = s.host == spined_dog.HOST and s.host_file is None
    return on_dog and s.gait in ("sine", "authors-raibert")


def world_host(s: Scenario) -> str:
    """What the world loads: a listed host's name, or the absolute path of the scenario's host file."""
    return str(Path(s.host_file).absolute()) if s.host_file is not None else s.host


def host_defaults(s: Scenario) -> dict[str, Any]:
    """The scenario keys the host's file sets for `s`'s gait ([defaults.<gait>] of its host.toml): only keys
    whose default depends on the robot (the nullable ones), each checked as the scenario checks it."""
    try:
        host = host_of(world_host(s))
    except (OSError, ValueError) as exc:
        raise ScenarioError("host_file" if s.host_file else "host", str(exc)) from None
    out = {}
    for name, value in host.defaults.get(s.gait, {}).items():
        if name not in KEYS or not KEYS[name].nullable:
            raise ScenarioError(name, f"{host.path}: [defaults.{s.gait}] may set only the keys whose default "
                                      "depends on the robot")
        out[name] = KEYS[name].check(value)
    return out


def defaults(s: Scenario) -> dict[str, Any]:
    """The default of every nullable key in `s`'s robot, gait and spine (keys that act only there)."""
    authors = authors_run(s)
    joints = dict(joint_damping=0.0, joint_friction=0.0)
    if s.gait == "authors-raibert":  # their later model and their script's spine
        k, d = A.RAIBERT_K, A.RAIBERT_D
        gait = dict(speed=_GAIT_C.speed_m_s, frequency=_GAIT_C.frequency_hz,
                    step_height=_GAIT_C.step_height_m)
        joints = dict(joint_damping=A.RAIBERT_JOINT_DAMPING_NM_S_RAD,
                      joint_friction=A.RAIBERT_JOINT_FRICTION_NM, leg_torque_limit=A.RAIBERT_LEG_LIMIT_NM)
        spine_rate = A.RAIBERT_CONTROL_HZ
    elif s.gait == "raibert":
        k, d = tuple(P.K_DEFAULT), tuple(P.D_DEFAULT)
        gait = dict(speed=_RAIBERT.speed_m_s if s.stride is None else None, frequency=_RAIBERT.frequency_hz,
                    step_height=_RAIBERT.step_height_m, body_kp=_RAIBERT.body_kp, body_kd=_RAIBERT.body_kd,
                    phase_offset=_RAIBERT.phase_offset, raibert_gain=_RAIBERT.raibert_gain_s,
                    height=_RAIBERT.height_m, roll_kp=_RAIBERT.roll_kp, roll_kd=_RAIBERT.roll_kd)
        spine_rate = None  # every physics step
    else:
        variant = s.variant or ("authors" if authors else "literal")
        run = A.gains(P.AUTHORS_SPINE_K[0])
        k, d = run.k, run.d
        gait = dict(variant=variant, frequency=_SINE.frequency_hz, step_height=_SINE.step_height_m,
                    step_length=_SINE.step_length_m,
                    hip_depth=_SINE.hip_depth_m, adapt_frequency=authors and variant == "authors",
                    direction=1.0 if variant == "literal" else None, schedule=True)
        spine_rate = A.AUTHORS_CONTROL_HZ if authors else P.AUTHORS_SPINE_RATE_HZ
    imu = A.EXACT_IMU if authors else ImuConfig()
    out = dict(gait, **joints, kx=k[0], kz=k[1], kth=k[2], dx=d[0], dz=d[1], dth=d[2],
               spine_rate_hz=spine_rate,
               imu_noise=imu.q1_noise_rad, imu_delay=imu.delay_steps,
               base_motion=A.BASE_MOTION if authors else "fixed")
    out.update(host_defaults(s))  # the host's own, over the gait's
    return {name: value for name, value in out.items()
            if s.gait in KEYS[name].gaits and s.spine in KEYS[name].spines}


def resolved(s: Scenario) -> Scenario:
    """`s` with every None key that acts in it set to its default: the run as it will be simulated."""
    fill = {name: value for name, value in defaults(s).items() if getattr(s, name) is None}
    if s.host_file is not None and not Path(s.host_file).is_absolute():
        fill["host_file"] = str(Path(s.host_file).absolute())  # re-runs from anywhere
    return replace(s, **fill) if fill else s


def bound_config(s: Scenario) -> BoundConfig:
    """The simulator's configuration of scenario `s` (defaults filled, the seed's perturbation applied);
    ScenarioError naming the key when its robot or engine cannot run it (`checks.check_runnable`)."""
    cfg = _bound_config(resolved(s))
    check_runnable(cfg)
    if s.spine_path == "node":
        _check_node_targets(cfg)
    return cfg


def _check_node_targets(cfg: BoundConfig) -> None:
    """The spine node refuses targets outside the workspace of the spine model it runs (this host's,
    spine_module.workspace): a run whose targets lie outside it would have the node refuse every command
    and stay disabled, so it is refused here, naming spine_path."""
    from spine_module import params as P
    from spine_module.workspace import Workspace

    sch = cfg.spine_schedule
    if sch is None:
        return
    ws = Workspace.of(cfg.spine_params if cfg.spine_params is not None else P.DEFAULT_SPINE)
    for x in {sch.x_d0_m, sch.x_d1_m}:
        why = ws.unreachable(x, sch.z_d_m, sch.theta_d_rad)
        if why is not None:
            raise ScenarioError("spine_path", f"node: the run's spine target ({x:g} m, {sch.z_d_m:g} m, "
                                              f"{sch.theta_d_rad:g} rad) is {why} of the node's spine "
                                              "model; use spine_path direct")


def spine_of(s: Scenario, cfg: BoundConfig):
    """The spine `s.spine_path` asks for: None (the controller called in process, `bound.run.run_bound`'s
    default) or the spine node on its in-process bus (the dog's spine model ranges over +-10 rad and
    starts at full gains: `authors_run.node_config`)."""
    if s.spine_path != "node":
        return None
    from sparc_quad.robot_side.quad import NodeSpine

    node_config = A.node_config() if cfg.spine_params is not None else None
    return NodeSpine.inprocess(cfg.spine, cfg.friction_compensation, node_config=node_config,
                               schedule=cfg.spine_schedule, spine=cfg.spine_params,
                               torso_accel=cfg.spine_torso_accel)


def _bound_config(r: Scenario) -> BoundConfig:
    pert = perturbation(r.seed)
    authors = authors_run(r)
    base_imu = A.EXACT_IMU if authors else ImuConfig()
    imu = replace(base_imu, q1_noise_rad=r.imu_noise, q1_bias_rad=r.imu_bias, delay_steps=r.imu_delay)
    world = WorldConfig(host=world_host(r), engine=r.engine, slope_rad=r.slope, seed=r.seed, imu=imu,
                        base_motion=r.base_motion, friction=WorldConfig.friction * pert.friction,
                        mass_scale=pert.mass_scale, init_pitch_rad=pert.init_pitch_rad,
                        init_vx_m_s=pert.init_vx_m_s)
    rendered = r.kx is not None
    spine = SpineGains(k=(r.kx, r.kz, r.kth), d=(r.dx, r.dz, r.dth)) if rendered else SpineGains()
    common: dict[str, Any] = dict(
        duration_s=r.duration, world=world, spine=spine, spine_variant=r.spine,
        friction_compensation=r.friction_comp, stop_on_fall=False, actuator_latency_steps=r.latency_steps,
        settle_s=r.settle, spine_rate_hz=r.spine_rate_hz)
    if r.host == spined_dog.HOST and r.host_file is None:  # the dog's own spine, in every gait
        common["spine_params"] = A.spine_params()
    world = replace(world, joint_damping_nm_s_rad=r.joint_damping, joint_friction_nm=r.joint_friction,
                    leg_torque_limit_nm=r.leg_torque_limit)
    common["world"] = world
    if r.gait == "authors-raibert":  # their start, their spine target and model, their locked model as rigid
        locked = r.spine == "rigid"
        params = replace(_GAIT_C, speed_m_s=r.speed, frequency_hz=r.frequency, step_height_m=r.step_height,
                         start_phase_rad=2 * math.pi * pert.start_phase_cycles,
                         start_spine_q_rad=LOCKED_SPINE_Q_RAD if locked else _GAIT_C.start_spine_q_rad)
        common.update(spine_params=A.spine_params(A.RAIBERT_EE_AHEAD_M), spine_torso_accel=False)
        target = A.raibert_target(spine.d) if r.spine != "rigid" else None
        return BoundConfig(gait=params, spine_schedule=target,
                           spine_timing="authors",
                           **{**common, "world": replace(world, lock_spine_q_rad=LOCKED_SPINE_Q_RAD)})
    if r.gait == "raibert":
        params = replace(_RAIBERT, frequency_hz=r.frequency, step_height_m=r.step_height, duty=r.duty,
                         body_kp=r.body_kp, body_kd=r.body_kd, phase_offset=r.phase_offset,
                         raibert_gain_s=r.raibert_gain, height_m=r.height, roll_kp=r.roll_kp,
                         roll_kd=r.roll_kd, start_s=_RAIBERT.start_s + pert.start_phase_cycles /
                         r.frequency)
        params = params.with_stride(r.stride) if r.stride is not None else replace(params, speed_m_s=r.speed)
        return BoundConfig(gait=params, **{**common, "world": replace(world, stand_height_m=r.height)})
    variant_authors = r.variant == "authors"
    sine = dict(frequency_hz=r.frequency, step_length_m=r.step_length, step_height_m=r.step_height,
                hip_depth_m=r.hip_depth, variant=r.variant, adapt_frequency=r.adapt_frequency,
                start_phase_rad=2 * math.pi * pert.start_phase_cycles)
    if r.direction is not None:
        sine["direction"] = r.direction
    world = replace(world, stand_height_m=r.hip_depth)
    if authors:  # their start pose and height, their schedule's frame, the dog's spine model
        sine.update(start_spine_q_rad=A.START_SPINE_Q_RAD, start_base_height_m=spined_dog.BASE_HEIGHT_M)
        schedule = A.schedule() if r.schedule or r.spine == "rigid-impedance" else None
        common.update(spine_params=A.spine_params(), spine_torso_accel=False)
    else:
        schedule = SpineSchedule() if r.schedule or r.spine == "rigid-impedance" else None
    params = SineBoundParams(**sine)
    params.validate()
    return BoundConfig(gait=params, spine_schedule=schedule,
                       spine_timing="authors" if variant_authors else "hold", **{**common, "world": world})
