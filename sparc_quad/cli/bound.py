"""`sparc-quad bound`: the spined quadruped bounding in pybullet or MuJoCo; writes metrics, a time series,
plots."""

from __future__ import annotations

import argparse
import logging
import signal
import threading
import warnings
from pathlib import Path

from sparc_quad.cli.args import (
    WAIT_MAX_S,
    add_spin_option,
    add_wake_latency_option,
    existing_file,
    lcm_url,
    output_dir,
    wait_s,
)
from sparc_quad.cli.errors import BadInput
from sparc_quad.cli.output import atomic_dir, moved
from sparc_quad.jsonfmt import json_text
from sparc_quad.scenario import (
    DEFAULTS,
    GAITS,
    KEYS,
    Key,
    Scenario,
    ScenarioError,
    bound_config,
    load_scenario,
)
from sparc_quad.sim.engines import engine_error
from spine_module.messages import channels

log = logging.getLogger(__name__)

SPEED_SHORTFALL = 0.75  # mean speed below this fraction of the target: the gait did not reach it
GROUPS = {  # scenario keys by option group, in the order --help lists them
    "the robot and its world": ("host", "host_file", "engine", "slope", "seed", "duration", "settle",
                                "latency_steps", "joint_damping", "joint_friction", "leg_torque_limit"),
    "the gait": ("gait", "speed", "stride", "frequency", "step_height", "duty", "height", "body_kp",
                 "body_kd", "roll_kp", "roll_kd", "phase_offset", "raibert_gain", "variant", "step_length",
                 "hip_depth", "direction", "adapt_frequency"),
    "the spine": ("spine", "spine_path", "kx", "kz", "kth", "dx", "dz", "dth", "friction_comp", "schedule",
                  "spine_rate_hz"),
    "the torso estimator": ("imu_noise", "imu_bias", "imu_delay", "base_motion"),
}


def option(name: str) -> str:
    """The command-line spelling of scenario key `name`."""
    return "--" + name.replace("_", "-")


def _parse(key: Key):
    """An argparse type for a scenario key: the key's own check, its message as argparse's error."""

    def parse(text: str):
        if key.kind is int or key.kind is float:
            try:
                value = key.kind(text) if key.kind is float else int(text, 10)
            except ValueError:
                raise argparse.ArgumentTypeError(
                    f"expected {'an integer' if key.kind is int else 'a number'}, got {text!r}") from None
        else:
            value = text
        try:
            return key.check(value)
        except ScenarioError as exc:
            raise argparse.ArgumentTypeError(exc.reason) from None

    parse.__name__ = {float: "number", int: "integer", str: "name"}[key.kind]
    return parse


def _help(key: Key) -> str:
    unit = f", {key.unit}" if key.unit else ""
    span = f" in {key.span()}" if key.kind in (int, float) else ""
    default = DEFAULTS[key.name]
    if default is None:
        shown = "the robot's and gait's"
    elif isinstance(default, bool):
        shown = "on" if default else "off"
    else:
        shown = f"{default:g}" if isinstance(default, float) else str(default)
    where = []
    if key.gaits != GAITS:
        where.append(f"gait {'/'.join(key.gaits)}")
    if set(key.spines) != set(KEYS["spine"].choices):
        where.append(f"spine {'/'.join(key.spines)}")
    acts = f"; acts with {' and '.join(where)} only" if where else ""
    default_text = "" if "default" in key.help else f" (default: {shown})"
    return f"{key.help}{unit}{span}{acts}{default_text}".replace("%", "%%")


def add_scenario_options(p: argparse.ArgumentParser) -> None:
    """One option per scenario key (`sparc_quad.scenario.KEYS`), absent from the namespace unless given."""
    listed = [n for names in GROUPS.values() for n in names]
    if sorted(listed) != sorted(KEYS):
        odd = sorted(set(KEYS) ^ set(listed))
        raise RuntimeError(f"bound: GROUPS must list every scenario key once: {odd}")
    for title, names in GROUPS.items():
        g = p.add_argument_group(title)
        for name in names:
            key = KEYS[name]
            if key.kind is bool:
                g.add_argument(option(name), dest=name, action=argparse.BooleanOptionalAction,
                               default=argparse.SUPPRESS, help=_help(key))
            elif key.choices is not None:
                g.add_argument(option(name), dest=name, choices=list(key.choices), default=argparse.SUPPRESS,
                               help=_help(key))
            else:
                g.add_argument(option(name), dest=name, type=_parse(key), default=argparse.SUPPRESS,
                               metavar=key.unit.upper().replace("*", "").replace("/", "_").replace(" ", "_")
                               or "N", help=_help(key))


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "bound",
        help="bound the SPARC-spined quadruped in pybullet or MuJoCo and measure it",
        description="Simulate the quadruped with the SPARC spine bounding (pybullet or MuJoCo, 1 kHz). Every "
        "option below the run options is a key of the run's scenario (sparc_quad.scenario; a study spec "
        "uses the same keys in snake_case). Writes scenario.json (the resolved scenario: re-run it with "
        "--scenario), metrics.json, timeseries.csv and (unless --no-plots) PNG plots to --out.",
    )
    r = p.add_argument_group("the run")
    r.add_argument("--scenario", type=existing_file, default=None, metavar="FILE",
                   help="start from this scenario (.toml or .json; a bound's scenario.json or a study trial "
                        "record re-runs that run); options given beside it override its keys")
    r.add_argument("--out", type=output_dir, default=Path("out/bound"), help="output folder")
    r.add_argument("--video", action="store_true", help="also render bound.gif (pybullet ER_TINY_RENDERER)")
    r.add_argument("--no-plots", action="store_true",
                   help="write scenario.json, metrics.json and timeseries.csv only (no PNGs; matplotlib "
                        "is not imported)")
    r.add_argument("--backend", choices=["auto", "numba", "python"], default="auto",
                   help="per-step code, the same results: numba (compiled spine step and bound controller; "
                        "~0.7 s CPU to load per process), python (the reference paths), auto (default): "
                        "numba for runs of 8 s or longer")
    r.add_argument("--realtime", action="store_true", help="pace the simulation to the wall clock")
    add_scenario_options(p)
    lcm = p.add_argument_group("the spine node in another process (--lcm)")
    lcm.add_argument("--lcm", action="store_true",
                     help="the spine node is another process (`sparc-quad spine-node --motors lcm`), over "
                          "LCM; lockstep unless --realtime (implies --spine-path node)")
    lcm.add_argument("--lcm-url", type=lcm_url, default=channels.DEFAULT_URL,
                     help="--lcm: LCM URL (default: $LCM_DEFAULT_URL or %(default)s)")
    lcm.add_argument("--lcm-node-states", action="store_true",
                     help="--lcm: also receive the node's spine states (SPARC_SPINE_STATE, 1 kHz) and write "
                          "them to node_states.npz. Off by default: each state wakes LCM's receiving "
                          "thread beside the simulation (measured ~30 %% of this process's CPU per tick on 2 "
                          "vCPUs); `lcm-logger` records them outside this process")
    add_spin_option(lcm, "--lcm-spin-us")
    add_wake_latency_option(lcm, "--lcm-wake-latency-us", when="--lcm (a simulation: off unless asked): ")
    lcm.add_argument("--wait-node", type=wait_s, default=30.0,
                     help=f"--lcm: wait this long (wall s, up to {WAIT_MAX_S:g}) for the node's first "
                          "heartbeat")
    p.set_defaults(lcm_only_defaults={name: p.get_default(name) for name in LCM_ONLY})
    p.set_defaults(func=run, extra="sim")


def given_keys(args: argparse.Namespace) -> dict:
    """The scenario keys given on the command line (the others are absent: argparse.SUPPRESS)."""
    return {name: getattr(args, name) for name in KEYS if hasattr(args, name)}


def scenario_from_args(args: argparse.Namespace) -> Scenario:
    """The run's scenario: `--scenario FILE` (or the defaults) with the given options on top; BadInput
    naming the option (or the file's key) on anything that cannot run."""
    given = given_keys(args)
    if getattr(args, "lcm", False):
        if given.get("spine_path", "node") != "node":
            raise BadInput("--spine-path direct with --lcm: the node in another process is the node path")
        given["spine_path"] = "node"
    try:
        base = load_scenario(args.scenario) if args.scenario is not None else Scenario()
    except ScenarioError as exc:
        raise BadInput(f"--scenario {args.scenario}: {exc}") from None
    try:
        return base.with_overrides(given)
    except ScenarioError as exc:
        if exc.key in given:
            raise BadInput(f"{option(exc.key)}: {exc.reason}") from None
        where = f" (with --scenario {args.scenario})" if args.scenario is not None else ""
        raise BadInput(f"{option(exc.key) if exc.key else 'scenario'}: {exc.reason}{where}") from None


def config_from_args(args: argparse.Namespace, scenario: Scenario | None = None):
    """The run's BoundConfig (imports the simulator); BadInput naming the option its robot or engine
    cannot run (`sparc_quad.scenario.checks`)."""
    from dataclasses import replace

    scenario = scenario if scenario is not None else scenario_from_args(args)
    try:
        cfg = bound_config(scenario)
    except ScenarioError as exc:
        raise BadInput(f"{option(exc.key) if exc.key else 'scenario'}: {exc.reason}") from None
    return replace(cfg, realtime=args.realtime, backend=args.backend)


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
    from sparc_quad import api

    if not args.lcm and lcm_only_given(args):
        raise BadInput(f"{', '.join(lcm_only_given(args))} act only with --lcm (the spine node in another "
                       "process); add --lcm or leave them out")

    if args.video and args.no_plots:
        raise BadInput("--video renders bound.gif with matplotlib: it cannot be combined with --no-plots")
    scenario = scenario_from_args(args)
    missing = engine_error(scenario.engine)
    if missing is not None:
        raise BadInput(missing)
    cfg = config_from_args(args, scenario)
    spine = None
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
                                       schedule=cfg.spine_schedule, torso_accel=cfg.spine_torso_accel,
                                       spine=cfg.spine_params)
        except ValueError as exc:
            raise BadInput(f"--lcm: host {scenario.host}: {exc}") from None
        except TimeoutError as exc:
            raise BadInput(f"--lcm: {exc}; start `sparc-quad spine-node --motors lcm --clock lockstep` "
                           "first") from exc
    # Ctrl-C sets a flag that the loop and the steps below check, so KeyboardInterrupt is raised in Python
    # code: raised inside a compiled extension's call it was, rarely, lost or reported twice (exit 0 or
    # death by SIGINT instead of 130; seen with the numba kernels loaded, ~1 run in 25 under load).
    # --lcm keeps Python's default handler: Ctrl-C must also break a wait for the node.
    stop = threading.Event()
    old_handler = None if args.lcm else signal.signal(signal.SIGINT, lambda signum, frame: stop.set())
    try:
        with atomic_dir(args.out) as tmp:  # --out keeps its previous result until this one is complete
            with warnings.catch_warnings():  # the short-window warning is printed once, below
                warnings.filterwarnings("ignore", message="steady window", category=RuntimeWarning)
                result = api.run_bound(scenario, spine=spine, video=args.video, stop=stop.is_set,
                                       realtime=args.realtime, backend=args.backend)
            if stop.is_set():
                raise KeyboardInterrupt
            paths = moved(api.write_outputs(result, tmp, plots=not args.no_plots), tmp, args.out)
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
