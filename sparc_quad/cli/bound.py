"""`sparc-quad bound`: the spined quadruped bounding in pybullet or MuJoCo; writes metrics, a time series,
plots."""

from __future__ import annotations

import argparse
import json
import logging
import math
import signal
import threading
from pathlib import Path

from sparc_quad.cli.args import (
    SIM_DURATION_MAX_S,
    WAIT_MAX_S,
    add_gain_options,
    add_spin_option,
    add_wake_latency_option,
    damping,
    fraction_open,
    in_range,
    lcm_url,
    output_dir,
    seed,
    sim_duration,
    stiffness,
    wait_s,
)
from sparc_quad.cli.errors import BadInput, bad_input
from sparc_quad.cli.output import atomic_dir, moved
from sparc_quad.gaits.bound import BoundParams
from sparc_quad.gaits.sine_bound import SineBoundParams
from sparc_quad.jsonfmt import json_text
from sparc_quad.sim.engines import DEFAULT_ENGINE, ENGINES, engine_error
from sparc_quad.sim.hosts import DEFAULT_HOST, HOSTS
from sparc_quad.sim.imu import ImuConfig
from sparc_quad.sim.quadruped_world import BASE_MOTIONS
from spine_module.messages import channels

log = logging.getLogger(__name__)

FREQUENCY_MAX_HZ = 10.0  # strides per second; a stance of < 25 control ticks cannot shape its force
SPEED_MAX_M_S = 10.0  # far beyond any quadruped of this size; `check_gait` below is the real limit
STRIDE_MAX_M = 2.0
BODY_KP_MAX = 1000.0  # N*m/rad: 0.01 rad of attitude error would already ask 10 N*m
BODY_KD_MAX = 100.0  # N*m*s/rad
IMU_NOISE_MAX_RAD = 1.0
IMU_DELAY_MAX_STEPS = 1000  # 1 s at 1 kHz
SPEED_SHORTFALL = 0.75  # mean speed below this fraction of the target: the gait did not reach it


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "bound",
        help="bound the SPARC-spined quadruped in pybullet or MuJoCo and measure it",
        description="Simulate the quadruped with the SPARC spine bounding (pybullet or MuJoCo, 1 kHz). "
        "Writes metrics.json, timeseries.csv and (unless --no-plots) PNG plots to --out.",
    )
    g, sg, imu = BoundParams(), SineBoundParams(), ImuConfig()
    add_gain_options(p)
    p.add_argument("--duration", type=sim_duration, default=10.0,
                   help=f"simulated time, s, at most {SIM_DURATION_MAX_S:g} (the log is kept in memory)")
    p.add_argument("--speed", type=in_range(0.0, SPEED_MAX_M_S), default=g.speed_m_s,
                   help="target forward speed, m/s; refused if its stance stride is beyond the legs' reach")
    p.add_argument("--gait", choices=["raibert", "sine"], default="raibert",
                   help="raibert: gait B, the Raibert-style bound (default); sine: gait A, the SPARC "
                        "authors' open-loop sine bound (sparc_quad/gaits/sine_bound.py)")
    p.add_argument("--frequency", type=in_range(0.0, FREQUENCY_MAX_HZ, lo_open=True), default=None,
                   help=f"stride frequency, Hz (default: {g.frequency_hz} raibert, {sg.frequency_hz} sine)")
    p.add_argument("--stride", type=in_range(0.0, STRIDE_MAX_M, lo_open=True), default=None,
                   help="stride length, m; sets the target speed to stride * frequency (overrides --speed)")
    p.add_argument("--step-height", type=in_range(0.0, g.height_m), default=None,
                   help=f"swing foot clearance, m (default: {g.step_height_m} raibert, "
                        f"{sg.step_height_m} sine)")
    p.add_argument("--step-length", type=in_range(0.0, STRIDE_MAX_M), default=sg.step_length_m,
                   help="--gait sine: L, half the fore-aft foot excursion about the hip (x = L cos phi), m")
    p.add_argument("--duty", type=fraction_open, default=None,
                   help="stance fraction of each leg pair (default: 0.5 at <= 0.3 m/s to 0.45 at >= 0.6 m/s)")
    p.add_argument("--slope", type=in_range(-math.pi / 2, math.pi / 2, lo_open=True, hi_open=True),
                   default=0.0, help="ground slope, rad, in (-pi/2, pi/2); > 0 uphill")
    p.add_argument("--rigid-spine", action="store_true",
                   help="baseline: spine joints locked at the equilibrium arch (pybullet fixed constraints)")
    p.add_argument("--spine-variant", choices=["impedance", "passive", "rigid", "rigid-impedance"],
                   default="impedance",
                   help="impedance: motor-rendered (default); passive: an ideal spring-damper with the same "
                        "gains (no actuator work); rigid: locked joints (= --rigid-spine); rigid-impedance: "
                        "the controller at k = 1e4 N/m")
    p.add_argument("--body-kp", type=in_range(0.0, BODY_KP_MAX), default=g.body_kp,
                   help="stance attitude servo per body, N*m/rad (pushes against spine flexion; 0 = off)")
    p.add_argument("--body-kd", type=in_range(0.0, BODY_KD_MAX), default=g.body_kd,
                   help="its damping, N*m*s/rad")
    p.add_argument("--friction-comp", action="store_true",
                   help="enable the controller's friction compensation")
    p.add_argument("--imu-noise", type=in_range(0.0, IMU_NOISE_MAX_RAD), default=imu.q1_noise_rad,
                   help="estimator q1 noise (standard deviation), rad")
    p.add_argument("--imu-bias", type=in_range(-math.pi, math.pi), default=0.0,
                   help="estimator q1 bias, rad")
    p.add_argument("--imu-delay", type=in_range(0, IMU_DELAY_MAX_STEPS, kind=int), default=imu.delay_steps,
                   help="estimator delay, 1 ms steps")
    p.add_argument("--base-motion", choices=list(BASE_MOTIONS), default=None,
                   help="what the torso estimate tells the spine law of the base's linear motion: fixed, "
                        "nothing (the base joint's origin does not accelerate: the paper's law, eq. 3); "
                        "constant-twist, the acceleration of the base joint's origin, m/s^2 in the hind-body "
                        "frame, of a body moving at a constant body-frame twist (v, w): a = w x v, the "
                        "assumption of the SPARC authors' law, from the hind body's true twist; "
                        "authors-cvel, the same a = w x v of what the authors' released code feeds that law: "
                        "MuJoCo's cvel "
                        "of the hind body one step late (w its angular velocity, v the velocity of the point "
                        "at the whole robot's centre of mass moving with it, both in world axes, read as if "
                        "they were the body-frame twist: their reading, not a physically consistent body "
                        "twist; pybullet computes the same quantity; needs --imu-delay >= 1 in MuJoCo). "
                        "Default: authors-cvel where the run is the authors' (--gait sine --host "
                        "spined-dog), fixed everywhere else")
    p.add_argument("--seed", type=seed, default=0, help="seed of every random number in the run")
    p.add_argument("--host", choices=HOSTS, default=DEFAULT_HOST,
                   help="host robot (robots/sparc_<host>, robots/spined_dog)")
    p.add_argument("--engine", choices=list(ENGINES), default=DEFAULT_ENGINE,
                   help="physics engine (mujoco needs the [mujoco] extra)")
    p.add_argument("--spine", choices=["direct", "node"], default="direct",
                   help="node: the spine node in this process on the in-process bus (the reference: soft "
                        "start, limits, watchdogs, CyberGear-quantised feedback); direct: the same "
                        "controller called in process with the node's limit damping and torque clamp, "
                        "without soft start, watchdogs or quantisation (fastest)")
    p.add_argument("--backend", choices=["auto", "numba", "python"], default="auto",
                   help="per-step code: numba (compiled spine step and bound controller; ~0.7 s CPU to load "
                        "per process), python (the reference paths), auto (default): numba for runs of "
                        "8 s or longer")
    p.add_argument("--lcm", action="store_true",
                   help="the spine node is another process (`sparc-quad spine-node --motors lcm`), over LCM; "
                        "lockstep unless --realtime")
    p.add_argument("--lcm-url", type=lcm_url, default=channels.DEFAULT_URL,
                   help="--lcm: LCM URL (default: $LCM_DEFAULT_URL or %(default)s)")
    p.add_argument("--lcm-node-states", action="store_true",
                   help="--lcm: also receive the node's spine states (SPARC_SPINE_STATE, 1 kHz) and write "
                        "them to node_states.npz. Off by default: each state wakes LCM's receiving thread "
                        "beside the simulation (measured ~30 %% of this process's CPU per tick on 2 vCPUs); "
                        "`lcm-logger` records them outside this process")
    add_spin_option(p, "--lcm-spin-us")
    add_wake_latency_option(p, "--lcm-wake-latency-us", when="--lcm: ")
    p.add_argument("--wait-node", type=wait_s, default=30.0,
                   help=f"--lcm: wait this long (wall s, up to {WAIT_MAX_S:g}) for the node's first "
                        "heartbeat")
    p.add_argument("--realtime", action="store_true", help="pace the simulation to the wall clock")
    p.add_argument("--out", type=output_dir, default=Path("out/bound"), help="output folder")
    p.set_defaults(lcm_only_defaults={name: p.get_default(name) for name in LCM_ONLY})
    p.add_argument("--video", action="store_true", help="also render bound.gif (pybullet ER_TINY_RENDERER)")
    p.add_argument("--no-plots", action="store_true",
                   help="write metrics.json and timeseries.csv only (no PNGs; matplotlib is not imported)")
    p.set_defaults(func=run, extra="sim")


def config_from_args(args: argparse.Namespace):
    """The run's BoundConfig (imports the simulator)."""
    from sparc_quad.sim.bound_run import BoundConfig
    from sparc_quad.sim.quadruped_world import WorldConfig
    from sparc_quad.sim.spine_drive import SpineGains

    given = {k: v for k, v in (("frequency_hz", args.frequency), ("step_height_m", args.step_height))
             if v is not None}
    if args.gait == "sine":
        gait = SineBoundParams(step_length_m=args.step_length, **given)
    else:
        gait = BoundParams(speed_m_s=args.speed, duty=args.duty, body_kp=args.body_kp, body_kd=args.body_kd,
                           **given)
        if args.stride is not None:
            gait = gait.with_stride(args.stride)
    imu = ImuConfig(q1_noise_rad=args.imu_noise, q1_bias_rad=args.imu_bias, delay_steps=args.imu_delay)
    world = WorldConfig(host=args.host, engine=args.engine, slope_rad=args.slope, seed=args.seed, imu=imu,
                        base_motion=args.base_motion or "fixed")
    if args.gait == "sine" and args.host == "spined-dog":  # their robot: their whole run (authors_run)
        from dataclasses import replace

        from sparc_quad.gaits import authors_run

        cfg = authors_run.bound_config(args.step_length, args.kx, args.duration, args.engine, **given)
        # the estimator options as given, else (all at their defaults) the exact, noise-free estimator
        world = replace(cfg.world, slope_rad=args.slope, seed=args.seed,
                        imu=imu if imu != ImuConfig() else cfg.world.imu,
                        base_motion=args.base_motion or cfg.world.base_motion)
        return replace(cfg, world=world,
                       spine_variant="rigid" if args.rigid_spine else args.spine_variant,
                       friction_compensation=args.friction_comp, stop_on_fall=False, realtime=args.realtime,
                       backend=args.backend)
    spine = SpineGains(k=stiffness(args), d=damping(args))
    return BoundConfig(
        duration_s=args.duration,
        gait=gait,
        world=world,
        spine=spine,
        spine_variant="rigid" if args.rigid_spine else args.spine_variant,
        friction_compensation=args.friction_comp,
        stop_on_fall=False,
        realtime=args.realtime,
        backend=args.backend,
    )


def check_world(cfg) -> None:
    """BadInput for an estimator the engine cannot feed: `authors-cvel` reads MuJoCo's cvel one step late,
    so the estimate must be at least that late (--imu-delay)."""
    from sparc_quad.sim.engines import world_class
    from sparc_quad.sim.quadruped_world import twist_lag_problem

    w = cfg.world
    if w.base_motion != "authors-cvel":
        return
    problem = twist_lag_problem(w.base_motion, world_class(w.engine).cvel_lag_steps, w.imu.delay_steps)
    if problem is not None:
        raise BadInput(f"--base-motion authors-cvel with --engine {w.engine}: {problem} (give --imu-delay 1 "
                       "or more, or another --base-motion)")


def check_gait(cfg) -> None:
    """BadInput for a gait the legs cannot walk: the sine bound's own check of its foot targets, and for
    the Raibert bound a stance longer than the legs can sweep at the gait's hip height (the target speed
    is then out of reach, whatever the controller does)."""
    from sparc_quad.gaits.bound import BoundParams
    from sparc_quad.sim.hosts import host_files

    legs = json.loads(host_files(cfg.world.host).meta.read_text())["legs"].values()
    reach = min(leg["thigh_m"] + leg["shank_m"] for leg in legs)
    gait = cfg.gait
    if not isinstance(gait, BoundParams):
        with bad_input(ValueError, prefix="--gait sine: "):
            gait.validate(reach)
        return
    if reach <= gait.height_m:
        return
    sweep_max = 2.0 * math.sqrt(reach**2 - gait.height_m**2)  # foot travel under the hip in one stance
    duty = gait.duty_at(gait.speed_m_s)
    sweep = gait.speed_m_s * duty / gait.frequency_hz
    if sweep > sweep_max:
        raise BadInput(f"--speed {gait.speed_m_s:g} m/s at {gait.frequency_hz:g} Hz needs a stance stride of "
                       f"{sweep:.3f} m; the {cfg.world.host} legs ({reach:.3f} m at hip height "
                       f"{gait.height_m:g} m) sweep at most {sweep_max:.3f} m: at most about "
                       f"{sweep_max * gait.frequency_hz / duty:.2f} m/s")


def speed_warning(metrics: dict, target_m_s: float | None) -> str | None:
    """A warning when a steady, standing run's mean speed stayed below SPEED_SHORTFALL x the target (the
    gait could not reach it), else None."""
    mean = metrics.get("speed_m_s")
    if not (metrics.get("window_ok") and not metrics.get("fell") and mean is not None and target_m_s):
        return None
    if mean >= SPEED_SHORTFALL * target_m_s:
        return None
    return (f"warning: mean speed {mean:.3f} m/s is below {SPEED_SHORTFALL:g} x the target {target_m_s:g} "
            "m/s: the gait did not reach the commanded speed")


# options that act only with --lcm: given without it they would be ignored, so they are refused
LCM_ONLY = ("lcm_url", "lcm_node_states", "lcm_spin_us", "lcm_wake_latency_us", "wait_node")


def lcm_only_given(args: argparse.Namespace) -> list[str]:
    """The --lcm options set to something other than their default (`--lcm-url` given as the default URL
    is not told apart: it changes nothing)."""
    return [f"--{name.replace('_', '-')}" for name, default in args.lcm_only_defaults.items()
            if getattr(args, name) != default]


def run(args: argparse.Namespace) -> int:
    from sparc_quad.sim.bound_run import run_bound, write_outputs

    if not args.lcm and lcm_only_given(args):
        raise BadInput(f"{', '.join(lcm_only_given(args))} act only with --lcm (the spine node in another "
                       "process); add --lcm or leave them out")

    if args.video and args.no_plots:
        raise BadInput("--video renders bound.gif with matplotlib: it cannot be combined with --no-plots")
    missing = engine_error(args.engine)
    if missing is not None:
        raise BadInput(missing)
    cfg = config_from_args(args)
    check_gait(cfg)
    check_world(cfg)
    spine = None
    if (args.rigid_spine or args.spine_variant != "impedance") and (args.lcm or args.spine == "node"):
        raise BadInput("--rigid-spine / --spine-variant other than impedance do not use the spine node")
    if args.lcm:
        from sparc_quad.robot_side.quad import NodeSpine
        from spine_module.node import realtime

        if args.lcm_wake_latency_us is not None:
            done = realtime.hold_wake_latency(args.lcm_wake_latency_us)
            log.log(logging.WARNING if " not " in done else logging.INFO, "bound --lcm: %s", done)
        try:
            spine = NodeSpine.over_lcm(cfg.spine, cfg.friction_compensation, url=args.lcm_url,
                                       lockstep=not args.realtime, wait_node_s=args.wait_node,
                                       spin_s=args.lcm_spin_us * 1e-6, node_states=args.lcm_node_states,
                                       schedule=cfg.spine_schedule, torso_accel=cfg.spine_torso_accel)
        except TimeoutError as exc:
            raise BadInput(f"--lcm: {exc}; start `sparc-quad spine-node --motors lcm --clock lockstep` "
                           "first") from exc
    elif args.spine == "node":
        from sparc_quad.robot_side.quad import NodeSpine

        node_config = None
        if args.gait == "sine" and args.host == "spined-dog":
            from sparc_quad.gaits import authors_run

            node_config = authors_run.node_config()
        spine = NodeSpine.inprocess(cfg.spine, cfg.friction_compensation, node_config=node_config,
                                    schedule=cfg.spine_schedule, spine=cfg.spine_params,
                                    torso_accel=cfg.spine_torso_accel)
    # Ctrl-C sets a flag that the loop and the steps below check, so KeyboardInterrupt is raised in Python
    # code: raised inside a compiled extension's call it was, rarely, lost or reported twice (exit 0 or
    # death by SIGINT instead of 130; seen with the numba kernels loaded, ~1 run in 25 under load).
    # --lcm keeps Python's default handler: Ctrl-C must also break a wait for the node.
    stop = threading.Event()
    old_handler = None if args.lcm else signal.signal(signal.SIGINT, lambda signum, frame: stop.set())
    try:
        with atomic_dir(args.out) as tmp:  # --out keeps its previous result until this one is complete
            result = run_bound(cfg, spine=spine, video=args.video, stop=stop.is_set)
            if stop.is_set():
                raise KeyboardInterrupt
            paths = moved(write_outputs(result, tmp, plots=not args.no_plots), tmp, args.out)
            if stop.is_set():
                raise KeyboardInterrupt
    finally:
        if old_handler is not None:
            signal.signal(signal.SIGINT, old_handler)
    m = result.metrics
    summary = {k: m.get(k) for k in ("fell", "fall_time_s", "fall_reason", "speed_m_s", "cot_pos_total",
                                      "cot_abs_total", "stride_frequency_hz", "stride_length_m",
                                      "peak_spine_torque_nm", "window_ok")}
    print(json_text(summary, indent=2))
    if not m.get("window_ok", False):
        print(f"warning: {m.get('warning', 'steady window too short')} (metrics.json has window_ok: false)")
    warning = speed_warning(m, getattr(cfg.gait, "speed_m_s", None))
    if warning:
        print(warning)
    for path in paths:
        print(f"wrote {path}")
    return 1 if m["fell"] else 0
