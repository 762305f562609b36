"""A trial with fixed gait parameters: config checking, the BoundConfig it maps to, and its run.

Split from `trial` so that gait family B (`raibert_opt`), which runs many fixed-gait trials inside its
search, and the `run_trial` dispatcher both depend on this module and not on each other.
"""

from __future__ import annotations

import math
from dataclasses import replace

from sparc_quad.gaits.bound import BoundParams
from sparc_quad.gaits.sine_bound import SineBoundParams
from sparc_quad.metrics import merge_disjoint
from sparc_quad.sim.bound_run import BoundConfig, run_bound
from sparc_quad.sim.engines import ENGINES
from sparc_quad.sim.hosts import HOSTS
from sparc_quad.sim.quadruped_world import WorldConfig
from sparc_quad.sim.seed_variation import perturbation
from sparc_quad.sim.spine_drive import SPINE_VARIANTS, SpineGains, SpineSchedule
from spine_module import params as P

GAITS = ("sine", "raibert", "raibert-opt")
# gait A in a study: the first Solo12 port ("literal") unless a trial names `variant = "authors"` (on Solo12
# the authors' start and arc fall within 0.4 s: the study's existing panels keep their gait)
STUDY_SINE_VARIANT = "literal"
_COMMON = {"gait", "spine", "duration", "seed", "slope", "latency_steps", "kx", "kz", "kth", "ktheta", "dx",
           "dz", "dth", "dtheta", "frequency", "step_height", "settle", "friction_comp", "host",
           "engine"}
_RAIBERT = {"speed", "duty", "stride", "body_kp", "body_kd", "phase_offset", "raibert_gain",
            "popsize", "iterations", "opt_duration", "opt_seed", "opt_restarts", "opt_trial_seeds", "tuned"}
_SINE = {"step_length", "adapt_frequency", "spine_rate_hz", "schedule", "hip_depth", "direction", "speed",
         "variant"}


def _num(config: dict, key: str, default: float) -> float:
    v = config.get(key, default)
    if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v):
        raise ValueError(f"config {key!r} must be a finite number, got {v!r}")
    return float(v)


def check_config(config: dict) -> None:
    """Raise ValueError naming the first bad key or value."""
    if not isinstance(config, dict):
        raise ValueError(f"config must be a dict, got {type(config).__name__}")
    gait = config.get("gait", "raibert")
    if gait not in GAITS:
        raise ValueError(f"config 'gait' must be one of {', '.join(GAITS)}, got {gait!r}")
    spine = config.get("spine", "impedance")
    if spine not in SPINE_VARIANTS:
        raise ValueError(f"config 'spine' must be one of {', '.join(SPINE_VARIANTS)}, got {spine!r}")
    allowed = _COMMON | (_SINE if gait == "sine" else _RAIBERT)
    unknown = sorted(set(config) - allowed)
    if unknown:
        raise ValueError(f"unknown config key(s) for gait {gait!r}: {', '.join(unknown)}")
    if _num(config, "duration", 10.0) <= 0:
        raise ValueError("config 'duration' must be > 0 s")
    seed = config.get("seed", 0)
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise ValueError(f"config 'seed' must be a non-negative integer, got {seed!r}")
    lat = config.get("latency_steps", 0)
    if isinstance(lat, bool) or not isinstance(lat, int) or lat < 0:
        raise ValueError(f"config 'latency_steps' must be a non-negative integer (1 ms steps), got {lat!r}")
    for key in ("kx", "kz", "kth", "ktheta", "dx", "dz", "dth", "dtheta"):
        if key in config and _num(config, key, 0.0) < 0:
            raise ValueError(f"config {key!r} must be >= 0, got {config[key]!r}")
    for key, names in (("host", HOSTS), ("engine", tuple(ENGINES))):
        if config.get(key, names[0]) not in names:
            raise ValueError(f"config {key!r} must be one of {', '.join(names)}, got {config[key]!r}")
    if abs(_num(config, "slope", 0.0)) > 0.5:
        raise ValueError(f"config 'slope' must be within +-0.5 rad, got {config['slope']!r}")


def spine_gains(config: dict, default_k, default_d) -> SpineGains:
    k = (_num(config, "kx", default_k[0]), _num(config, "kz", default_k[1]),
         _num(config, "kth", _num(config, "ktheta", default_k[2])))
    d = (_num(config, "dx", default_d[0]), _num(config, "dz", default_d[1]),
         _num(config, "dth", _num(config, "dtheta", default_d[2])))
    return SpineGains(k=k, d=d)


def bound_config(config: dict) -> BoundConfig:
    """The BoundConfig of a trial config (seed perturbation applied)."""
    check_config(config)
    gait = config.get("gait", "raibert")
    seed = int(config.get("seed", 0))
    pert = perturbation(seed)
    duration = _num(config, "duration", 10.0)
    world = WorldConfig(host=config.get("host", "solo12"), engine=config.get("engine", "pybullet"),
                        slope_rad=_num(config, "slope", 0.0), seed=seed,
                        friction=WorldConfig.friction * pert.friction, mass_scale=pert.mass_scale,
                        init_pitch_rad=pert.init_pitch_rad, init_vx_m_s=pert.init_vx_m_s)
    common = dict(duration_s=duration, world=world, spine_variant=config.get("spine", "impedance"),
                  friction_compensation=bool(config.get("friction_comp", False)), stop_on_fall=False,
                  actuator_latency_steps=int(config.get("latency_steps", 0)),
                  settle_s=_num(config, "settle", 1.0))
    if gait == "sine" and config.get("variant") == "authors" and world.host == "spined-dog":
        return _authors_run(config, world, common, pert)
    if gait == "sine":
        d = SineBoundParams()
        f = _num(config, "frequency", d.frequency_hz)
        params = SineBoundParams(
            frequency_hz=f, step_length_m=_num(config, "step_length", d.step_length_m),
            step_height_m=_num(config, "step_height", d.step_height_m),
            hip_depth_m=_num(config, "hip_depth", d.hip_depth_m),
            direction=_num(config, "direction", d.direction),
            variant=str(config.get("variant", STUDY_SINE_VARIANT)),
            adapt_frequency=bool(config.get("adapt_frequency", False)),
            start_phase_rad=2 * math.pi * pert.start_phase_cycles)
        params.validate()
        world = replace(world, stand_height_m=params.hip_depth_m)
        schedule = SpineSchedule() if config.get("schedule", True) else None
        return BoundConfig(gait=params, spine=spine_gains(config, P.AUTHORS_SPINE_K, P.AUTHORS_SPINE_D_RUN),
                           spine_schedule=schedule,
                           spine_rate_hz=_num(config, "spine_rate_hz", P.AUTHORS_SPINE_RATE_HZ),
                           spine_timing="authors" if params.authors else "hold",
                           **{**common, "world": world})
    d = BoundParams()
    f = _num(config, "frequency", d.frequency_hz)
    if f <= 0:
        raise ValueError("config 'frequency' must be > 0 Hz")
    params = replace(d, frequency_hz=f, speed_m_s=_num(config, "speed", d.speed_m_s),
                     step_height_m=_num(config, "step_height", d.step_height_m),
                     duty=_num(config, "duty", 0.0) if "duty" in config else None,
                     body_kp=_num(config, "body_kp", d.body_kp), body_kd=_num(config, "body_kd", d.body_kd),
                     phase_offset=_num(config, "phase_offset", d.phase_offset),
                     raibert_gain_s=_num(config, "raibert_gain", d.raibert_gain_s),
                     start_s=d.start_s + pert.start_phase_cycles / f)
    if "stride" in config:
        params = params.with_stride(_num(config, "stride", 0.0))
    return BoundConfig(gait=params, spine=spine_gains(config, P.K_DEFAULT, P.D_DEFAULT), **common)


def _authors_run(config: dict, world: WorldConfig, common: dict, pert) -> BoundConfig:
    """Gait A on the spined dog as the authors run it (sparc_quad.gaits.authors_run: their start, clock,
    spine schedule on the dog's spine-only model, noise-free estimator one step late), with the study's
    seed perturbation, spine variant, gains, latency and window on top."""
    from sparc_quad.gaits import authors_run as A

    d = SineBoundParams()
    base = A.bound_config(step_length_m=_num(config, "step_length", d.step_length_m),
                          k_x_n_m=_num(config, "kx", P.AUTHORS_SPINE_K[0]), duration_s=common["duration_s"],
                          engine=world.engine, adapt_frequency=bool(config.get("adapt_frequency", True)),
                          frequency_hz=_num(config, "frequency", d.frequency_hz),
                          step_height_m=_num(config, "step_height", d.step_height_m),
                          start_phase_rad=2 * math.pi * pert.start_phase_cycles)
    base.gait.validate()
    run_gains = A.gains(base.spine.k[0])
    spine = spine_gains(config, run_gains.k, run_gains.d)
    w = replace(base.world, slope_rad=world.slope_rad, seed=world.seed, friction=world.friction,
                mass_scale=world.mass_scale, init_pitch_rad=world.init_pitch_rad,
                init_vx_m_s=world.init_vx_m_s)
    return replace(base, spine=spine, **{**common, "world": w})


def _flat(metrics: dict) -> dict:
    out: dict = {}
    for k, v in metrics.items():
        if k == "strides":
            continue
        if isinstance(v, dict):
            for kk, vv in _flat(v).items():
                out[f"{k}_{kk}"] = vv
        elif isinstance(v, list | tuple):
            for i, vv in enumerate(v):
                out[f"{k}_{i}"] = float("nan") if vv is None else vv
        elif v is None:
            out[k] = float("nan")
        else:
            out[k] = v
    return out


def run_fixed_trial(config: dict) -> dict:
    """One trial with the gait parameters as given (gait A, or the Raibert bound untuned)."""
    cfg = bound_config(config)
    result = run_bound(cfg)
    m = result.metrics
    out = merge_disjoint(_flat({k: v for k, v in m.items() if k != "strides"}),
                         perturbation(int(config.get("seed", 0))).as_metrics())
    out["strides"] = m["strides"]
    out["gait"] = config.get("gait", "raibert")
    out["spine"] = config.get("spine", "impedance")
    out["fall_reason"] = m.get("fall_reason") or ""
    return out
