"""`sparc-quad bench static|dynamic|pd|all`: the paper's bench experiments on the simulated spine."""

from __future__ import annotations

import argparse
import contextlib
from collections.abc import Iterator
from dataclasses import replace
from pathlib import Path

from sparc_quad.cli.args import add_gain_options, in_range, output_dir, seed
from sparc_quad.cli.output import atomic_dir
from spine_module import params as P

UNITS = "Units: stiffness N/m, damping N*s/m, displacement m, force N, time s."
QUASI_STATIC = {"dx": P.BENCH_QUASI_STATIC_D_X_N_S_M}
TRIALS_MAX = 1000  # each trial is seconds of simulation: more is hours of CPU and a typo


def _common(p: argparse.ArgumentParser) -> None:
    p.add_argument("--out", type=output_dir, default=Path("out/bench"), help="output folder")
    p.add_argument("--seed", type=seed, default=0, help="noise seed of the first trial")
    p.add_argument("--plant", type=_plant_file, default=None, metavar="JSON",
                   help="plant-model JSON (friction truth, rotor inertia, sensors) (default: the simulated "
                        "bench's own, sparc_quad.sim.plant.PlantConfig)")
    p.add_argument("--ideal-plant", action="store_true",
                   help="plant equal to the controller's model: no friction mismatch, quantisation or noise")
    p.add_argument("--quick", action="store_true", help="reduced-size run (fewer values, shorter trials)")


def _trials(per: str, default: int) -> dict[str, object]:
    """--trials of an experiment that repeats trials: None unless given, so the config keeps its own
    default (`default`, which the help names)."""
    return {"type": in_range(1, TRIALS_MAX, kind=int), "default": None,
            "help": f"trials per {per}, up to {TRIALS_MAX} (default: {default})"}


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("bench", help="the paper's bench experiments (Table IV, Fig. 5, Fig. 7) in simulation",
                       description="Run the SPARC paper's bench experiments on the simulated bench. " + UNITS)
    bsub = p.add_subparsers(dest="experiment", metavar="EXPERIMENT", required=True)
    experiments = (  # name, help, what it writes, swept gains, gain defaults, its own option, run
        ("static", "quasi-static push-pull, stiffness by OLS (Table IV, Fig. 4)",
         "Push-pull along x; writes static.json, static.csv, static.png.",
         ("kx",), {"kx": P.BENCH_STATIC_K_X_N_M, **QUASI_STATIC},
         ("--controller", {"choices": ["impedance", "pd"], "default": "impedance",
                           "help": "impedance: eq. (2)-(4) with friction compensation; pd: task-space PD "
                                   "(Fig. 7)"}), run_static),
        ("dynamic", "displace 0.037 m and release (Fig. 5)",
         "Release trials; writes dynamic.json and dynamic.png.",
         ("kx", "dx"), {"kx": P.BENCH_DYNAMIC_K_X_N_M, "dx": P.BENCH_DYNAMIC_D_X_N_S_M},
         ("--trials", _trials("case", 10)), run_dynamic),
        ("pd", "task-space PD vs impedance, quasi-static holds (Fig. 7)",
         "Hand-held displacements; writes pd.json and pd.png.",
         ("kx",), {"kx": P.BENCH_PD_K_X_N_M, **QUASI_STATIC},
         ("--trials", _trials("k", 5)), run_pd),
    )
    for name, help_, writes, sweep, defaults, (flag, option), func in experiments:
        e = bsub.add_parser(name, help=help_, description=f"{writes} {UNITS}")
        add_gain_options(e, sweep=sweep, defaults=defaults)
        e.add_argument(flag, **option)
        _common(e)
        e.set_defaults(func=func)
    a = bsub.add_parser("all", help="static, dynamic and pd in one go",
                        description="All three experiments into one folder. " + UNITS)
    _common(a)
    a.set_defaults(func=run_all)
    p.set_defaults(extra="sim")


def _plant_file(text: str):
    """--plant FILE, read and checked while parsing: a bad file is a usage error (exit 2) naming the file
    and the field, before any experiment starts."""
    from sparc_quad.sim.plant import PlantConfig

    try:
        return PlantConfig.load(Path(text))
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def _plant(args: argparse.Namespace):
    from sparc_quad.sim.plant import PlantConfig

    plant = args.plant if args.plant is not None else PlantConfig()
    return plant.ideal() if args.ideal_plant else plant


def _given(args: argparse.Namespace, **fields: str) -> dict[str, object]:
    """Config fields from the options a subcommand has (`bench all` has none: the configs' defaults)."""
    return {f: getattr(args, a) for f, a in fields.items() if getattr(args, a, None) is not None}


def _quasi_static_gains(args: argparse.Namespace) -> dict[str, object]:
    out = _given(args, k_values="kx", k_z="kz", k_theta="kth")
    if hasattr(args, "dx"):
        out["d"] = (args.dx, args.dz, args.dth)
    return out


@contextlib.contextmanager
def _out(args: argparse.Namespace) -> Iterator[Path]:
    """Where an experiment writes: a temporary sibling of --out that replaces it when complete (the other
    experiments' files in --out are kept); `bench all` writes its three into one such folder."""
    if getattr(args, "write_to", None) is not None:
        yield args.write_to
        return
    with atomic_dir(args.out) as tmp:
        yield tmp


def _progress(items, desc: str, unit: str):
    from tqdm import tqdm

    return tqdm(items, desc=desc, unit=unit)


def run_static(args: argparse.Namespace) -> int:
    from sparc_quad.experiments import static

    cfg = static.StaticConfig(controller=getattr(args, "controller", "impedance"), seed=args.seed,
                              plant=_plant(args), **_quasi_static_gains(args))
    if args.quick:
        cfg = replace(cfg, period_s=4.0, cycles=1, sample_every=3)
    with _out(args) as out:
        rows, raw = static.run_static(cfg, _progress(cfg.k_values, "static k_x", "k"))
        static.write_static(rows, raw, cfg, out)
    print(static.format_table(rows))
    print(f"wrote {args.out / 'static.json'}, static.csv, static.png")
    return 0


def run_dynamic(args: argparse.Namespace) -> int:
    from sparc_quad.experiments import dynamic

    cfg = dynamic.DynamicConfig(seed=args.seed, plant=_plant(args),
                                **_given(args, k_values="kx", b_values="dx", k_z="kz", k_theta="kth",
                                         d_z="dz", d_theta="dth", trials="trials"))
    if args.quick:
        cfg = replace(cfg, trials=3, duration_s=1.2)
    pairs = [(k, b) for k in cfg.k_values for b in cfg.b_values]
    with _out(args) as out:
        cases, curves = dynamic.run_dynamic(cfg, _progress(pairs, "dynamic (k, b)", "case"))
        dynamic.write_dynamic(cases, curves, cfg, out)
    print(f"{'k':>5} {'b':>5} {'NRMSE':>7} {'zeta':>6} {'fit':>6} {'lag0':>6} {'drift':>6} {'growth':>6}")
    print(f"{'N/m':>5} {'N*s/m':>5} {'1':>7} {'1':>6} {'1':>6} {'rad':>6} {'rad':>6} {'1':>6}")
    for c in cases:
        def f(v: float | None) -> str:
            return f"{v:6.3f}" if v is not None else "     -"
        print(f"{c.k:5.0f} {c.b:5.0f} {c.nrmse:7.4f} {c.zeta_ideal:6.3f} {f(c.zeta_fit)} "
              f"{f(c.phase_lag_first_rad)} {f(c.phase_drift_rad)} {f(c.amplitude_growth)}")
    print("k, b: commanded x stiffness and damping; NRMSE: RMS of the mean response minus the ideal "
          "spring-damper's, over the release displacement; zeta: the ideal damping ratio b / (2 sqrt(k m)); "
          "fit: the damping ratio fitted to the measured decay; lag0: phase lag behind the ideal at the "
          "first zero crossing; drift: its change to the last crossing; growth: last peak / first peak of "
          "|x - x_d|; -: not defined (too few crossings or peaks above 5 % of the release, e.g. overdamped)")
    print(f"wrote {args.out / 'dynamic.json'}, dynamic.png")
    return 0


def run_pd(args: argparse.Namespace) -> int:
    from sparc_quad.experiments import pd

    cfg = pd.PDConfig(seed=args.seed, plant=_plant(args), **_quasi_static_gains(args),
                      **_given(args, trials="trials"))
    if args.quick:
        cfg = replace(cfg, trials=3, displacements_m=(0.01, 0.02, 0.03))
    pairs = [(c, k) for c in cfg.controllers for k in cfg.k_values]
    with _out(args) as out:
        rows = pd.run_pd(cfg, _progress(pairs, "pd (controller, k_x)", "k"))
        pd.write_pd(rows, cfg, out)
    print(f"{'controller':>10} {'k_x':>5} {'slope mean':>10} {'slope SD':>9} {'R2':>7}")
    print(f"{'':>10} {'N/m':>5} {'N/m':>10} {'N/m':>9} {'1':>7}")
    for r in rows:
        print(f"{r.controller:>10} {r.k_cmd:5.0f} {r.slope_mean:10.1f} {r.slope_sd:9.2f} {r.r2_pooled:7.4f}")
    print(f"wrote {args.out / 'pd.json'}, pd.png")
    return 0


def run_all(args: argparse.Namespace) -> int:
    with atomic_dir(args.out) as tmp:
        each = argparse.Namespace(**{**vars(args), "write_to": tmp})
        return run_static(each) or run_dynamic(each) or run_pd(each)
