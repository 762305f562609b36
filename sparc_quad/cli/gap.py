"""`sparc-quad gap`: name the physical effect behind a sim-vs-measured gap.

    sparc-quad gap TRIAL.csv [TRIAL.csv ...] --out DIR [--plant NOMINAL.json] [--window 0.2]
    sparc-quad gap synth --effect NAME[:joint=q3,param=value,...] [--effect ...] --out DIR [--seed N]
    sparc-quad gap synth-arm --out DIR [--seed N] [--joint-side] [--uncoupled] [--no-dq]
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from sparc_quad.cli.args import nonnegative_int, positive_float, positive_int
from sparc_quad.cli.output import atomic_dir, moved
from sparc_quad.effects import names as effect_names


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "gap", help="sim-vs-measured gap: locate, name the missing effect, write a plant file",
        description="gap TRIAL... --out DIR | gap synth --effect NAME[:joint=..,param=..] --out DIR. "
                    f"Effects: {', '.join(effect_names())}.")
    p.add_argument("trials", nargs="+", metavar="TRIAL",
                   help="trial CSVs (sidecar JSON with the same stem) or lcm-logger files; "
                        "or the word 'synth' (spine) or 'synth-arm' (6-DoF arm) to make trials")
    p.add_argument("--out", type=Path, required=True, help="output folder")
    p.add_argument("--plant", type=Path, default=None,
                   help="nominal plant-effects file (default: the sidecar's 'plant' key, else none)")
    p.add_argument("--window", type=positive_float, default=0.2, help="replay window length, s (default 0.2)")
    p.add_argument("--cutoff", type=positive_float, default=None,
                   help="low-pass cut-off before differentiation, Hz (default: from the data's bandwidth)")
    p.add_argument("--max-effects", type=positive_int, default=None,
                   help="cap on the number of effects named (default: none)")
    p.add_argument("--no-plots", action="store_true", help="skip the PNG plots and report.md")
    g = p.add_argument_group("synth")
    g.add_argument("--effect", action="append", default=[], metavar="NAME[:k=v,...]",
                   help="hidden effect (repeatable), e.g. coulomb_friction:joint=q3,tau_c_nm=0.15")
    g.add_argument("--seed", type=nonnegative_int, default=0)
    g.add_argument("--trials-n", type=positive_int, default=3, help="number of trials (default 3)")
    g.add_argument("--periods", type=positive_int, default=None,
                   help="excitation periods per trial (default 4; synth-arm 2)")
    g.add_argument("--period", type=positive_float, default=1.5, help="excitation period, s (default 1.5)")
    g.add_argument("--unmodelled", choices=["cogging"], default=None,
                   help="also add an effect outside the library")
    a = p.add_argument_group("synth-arm (UR5 with massless flange, friction + rotor inertia on every motor, "
                             "link inertial errors, coupled wrist, measured currents, 5 kHz)")
    a.add_argument("--joint-side", action="store_true",
                   help="write joint-side columns in N*m (default: motor side as a real arm logs it)")
    a.add_argument("--uncoupled", action="store_true", help="no wrist coupling (motor 6 turns q6 only)")
    a.add_argument("--no-dq", action="store_true", help="leave out the velocity columns")
    p.set_defaults(func=run, extra="gap")


def run(args: argparse.Namespace) -> int:
    from sparc_quad.effects import PlantEffectsError
    from sparc_quad.gap.errors import NumericalError, TrialError

    try:
        if args.trials == ["synth"]:
            from sparc_quad.gap.synth import synth

            with atomic_dir(args.out) as tmp:
                res = synth(tmp, args.effect, seed=args.seed, n_trials=args.trials_n,
                            periods=args.periods or 4, period_s=args.period, unmodelled=args.unmodelled)
            for pth in moved(res["trials"], tmp, args.out):
                print(pth)
            print(f"hidden effects: {json.dumps([e.to_dict() for e in res['hidden']])}")
            return 0
        if args.trials == ["synth-arm"]:
            return _synth_arm(args)
        from sparc_quad.gap.workflow import run as run_gap

        with atomic_dir(args.out) as tmp:
            rep = run_gap(args.trials, tmp, nominal_plant=args.plant, window_s=args.window,
                          cutoff_hz=args.cutoff, plots=not args.no_plots, max_effects=args.max_effects)
    except (TrialError, PlantEffectsError, ValueError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    except NumericalError as exc:  # the input was accepted; a computation on it failed
        print(f"numerical failure (not bad input): {exc}", file=sys.stderr)
        return 1
    names = ", ".join(f"{e['name']}@{e['joint']}" for e in rep["effects"]) or "none"
    print(f"verdict: {rep['verdict']}; effects: {names}; ambiguous: {len(rep['ambiguous'])}")
    print(f"report: {args.out / 'report.json'}  plant: {args.out / 'plant.json'}")
    return 0


def _synth_arm(args: argparse.Namespace) -> int:
    from sparc_quad.gap.synth_arm import ArmCase, synth_arm

    with atomic_dir(args.out) as tmp:
        res = synth_arm(tmp, seed=args.seed, n_trials=args.trials_n, periods=args.periods or 2,
                        period_s=args.period, case=ArmCase(coupled_wrist=not args.uncoupled),
                        motor_side=not args.joint_side, with_dq=not args.no_dq)
    for pth in moved(res["trials"], tmp, args.out):
        print(pth)
    print(f"truth: {args.out / 'truth.json'} ({len(res['truth']['hidden'])} hidden effects; "
          "the last trial is the held-out one)")
    return 0
