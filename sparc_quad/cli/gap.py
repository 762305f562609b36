"""`sparc-quad gap run|synth|import`: name the physical effect behind a sim-vs-measured gap.

    sparc-quad gap run TRIAL.csv [TRIAL.csv ...] --out DIR [--plant NOMINAL.json] [--window 0.2]
    sparc-quad gap synth --effect NAME[:joint=q3,param=value,...] [--effect ...] --out DIR [--seed N]
    sparc-quad gap synth --arm --out DIR [--seed N] [--joint-side] [--uncoupled] [--no-dq]
    sparc-quad gap import panda|tx40 --source DIR --out DIR [--window START:END ...]
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from sparc_quad.cli.args import SIM_DURATION_MAX_S, existing_file, in_range, output_dir, seed
from sparc_quad.cli.errors import BadInput, bad_input
from sparc_quad.cli.output import atomic_dir, moved
from sparc_quad.effects import names as effect_names
from sparc_quad.gap import import_panda, import_tx40

WINDOW_MAX_S = 10.0  # a replay window is a fraction of a second to seconds; longer ones never fit a trial
TRIALS_MAX = 1000  # trials are written one by one: the count bounds run time, not memory
PERIODS_MAX = 100
IMPORTERS = {"panda": import_panda, "tx40": import_tx40}
ACTIONS = ("run", "synth", "import")


def legacy_argv(argv: list[str]) -> list[str]:
    """The earlier spellings, still accepted: `gap TRIAL...` is `gap run TRIAL...`, `gap synth-arm` is
    `gap synth --arm` (a note on stderr says so). A word close to an action that is no file (`gap synthh`)
    is left for the parser, which says "did you mean synth" (it is no trial: "synthh: file not found")."""
    import difflib
    import sys

    i = next((k for k, a in enumerate(argv) if not a.startswith("-")), None)
    if i is None or argv[i] != "gap" or i + 1 >= len(argv) or argv[i + 1].startswith("-"):
        return argv
    word = argv[i + 1]
    if word == "synth-arm":
        new = [*argv[:i + 1], "synth", "--arm", *argv[i + 2:]]
    elif word in ACTIONS or (difflib.get_close_matches(word, ACTIONS, n=1, cutoff=0.75)
                             and not Path(word).exists()):
        return argv
    else:
        new = [*argv[:i + 1], "run", *argv[i + 1:]]
    print(f"sparc-quad gap: note: `gap {word} ...` is now `{' '.join(new[i:i + 3])} ...`", file=sys.stderr)
    return new


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "gap", help="sim-vs-measured gap: locate, name the missing effect, write a plant file",
        description="gap run TRIAL... --out DIR | gap synth --effect NAME[:joint=..,param=..] --out DIR | "
                    f"gap import panda|tx40 --source DIR --out DIR. Effects: {', '.join(effect_names())}.")
    p.set_defaults(extra="gap")
    gsub = p.add_subparsers(dest="gap_command", metavar="ACTION", required=True)

    r = gsub.add_parser("run", help="find and name the effects behind the gap in measured trials",
                        description="Replay the trials through the nominal model, locate the gap, name the "
                                    "effects that close it; writes report.json, plant.json (and plots).")
    r.add_argument("trials", nargs="+", metavar="TRIAL",
                   help="trial CSVs (sidecar JSON with the same stem) or lcm-logger files")
    r.add_argument("--out", type=output_dir, required=True, help="output folder")
    r.add_argument("--plant", type=existing_file, default=None, metavar="JSON",
                   help="nominal plant-effects file (default: the sidecar's 'plant' key, else none)")
    r.add_argument("--window", type=in_range(0.0, WINDOW_MAX_S, lo_open=True), default=0.2,
                   help=f"replay window length, s, up to {WINDOW_MAX_S:g}")
    r.add_argument("--cutoff", type=in_range(0.0, 1e5, lo_open=True), default=None,
                   help="low-pass cut-off before differentiation, Hz (default: from the data's bandwidth)")
    r.add_argument("--max-effects", type=in_range(1, 50, kind=int), default=None,
                   help="cap on the number of effects named (default: none)")
    r.add_argument("--no-plots", action="store_true", help="skip the PNG plots and report.md")
    r.set_defaults(func=run)

    s = gsub.add_parser("synth", help="make synthetic trials with hidden effects (the spine, or --arm)",
                        description="Simulate trials of the spine (or, with --arm, a 6-DoF arm) with hidden "
                                    "effects; writes trial CSVs and the truth beside them.")
    s.add_argument("--out", type=output_dir, required=True, help="output folder")
    s.add_argument("--seed", type=seed, default=0, help="seed of the excitation and the noise")
    s.add_argument("--trials-n", type=in_range(1, TRIALS_MAX, kind=int), default=3,
                   help=f"number of trials, up to {TRIALS_MAX}")
    s.add_argument("--periods", type=in_range(1, PERIODS_MAX, kind=int), default=None,
                   help="excitation periods per trial (default: 4; --arm 2)")
    s.add_argument("--period", type=in_range(0.0, SIM_DURATION_MAX_S, lo_open=True), default=1.5,
                   help="excitation period, s")
    sp = s.add_argument_group("spine")
    sp.add_argument("--effect", action="append", default=[], metavar="NAME[:k=v,...]",
                    help="hidden effect (repeatable), e.g. coulomb_friction:joint=q3,tau_c_nm=0.15 "
                         "(default: none)")
    sp.add_argument("--unmodelled", choices=["cogging"], default=None,
                    help="also add an effect outside the library")
    a = s.add_argument_group("--arm (UR5 with massless flange, friction + rotor inertia on every motor, "
                             "link inertial errors, coupled wrist, measured currents, 5 kHz)")
    a.add_argument("--arm", action="store_true", help="the arm instead of the spine")
    a.add_argument("--joint-side", action="store_true",
                   help="write joint-side columns in N*m (default: motor side as a real arm logs it)")
    a.add_argument("--uncoupled", action="store_true", help="no wrist coupling (motor 6 turns q6 only)")
    a.add_argument("--no-dq", action="store_true", help="leave out the velocity columns")
    s.set_defaults(func=run_synth)

    i = gsub.add_parser("import", help="import a real robot's identification log as gap trials",
                        description="Convert a published identification log into trial CSVs for `gap run`.")
    isub = i.add_subparsers(dest="robot", metavar="ROBOT", required=True)
    for name, mod in IMPORTERS.items():
        ip = isub.add_parser(name, help=mod.__doc__.split("\n")[0], description=mod.__doc__.split("\n")[0])
        checked = {"out": output_dir, "factor": in_range(1, 1000, kind=int)}
        if name == "panda":  # resamples
            checked["rate"] = in_range(0.0, 1e5, lo_open=True)
        mod.add_arguments(ip, **checked)
        ip.set_defaults(func=run_import, importer=mod)


def _gap_errors() -> tuple[type[BaseException], ...]:
    """The gap library's bad-input errors (anything else it raises is a bug, reported as one)."""
    from sparc_quad.effects import PlantEffectsError
    from sparc_quad.gap.errors import TrialError

    return (TrialError, PlantEffectsError)


def run(args: argparse.Namespace) -> int:
    from sparc_quad.effects.plant import PlantEffects
    from sparc_quad.gap.errors import NumericalError
    from sparc_quad.gap.workflow import load_trials
    from sparc_quad.gap.workflow import run as run_gap

    with bad_input(*_gap_errors()):  # every input checked before anything is created
        trials = load_trials(args.trials)
        plant_file = args.plant or trials[0].plant_path()
        if plant_file is not None:
            PlantEffects.load(plant_file)
    try:
        with atomic_dir(args.out) as tmp, bad_input(*_gap_errors()):
            rep = run_gap(args.trials, tmp, nominal_plant=args.plant, window_s=args.window,
                          cutoff_hz=args.cutoff, plots=not args.no_plots, max_effects=args.max_effects,
                          trials=trials)
    except NumericalError as exc:  # the input was accepted; a computation on it failed
        print(f"sparc-quad gap run: numerical failure (not bad input): {exc}", file=sys.stderr)
        return 1
    for src in rep.get("log_sources", []):
        if src["gaps"] or src["dropped_segments"] or src["lacks"]:
            lacks = "; ".join(x.split(":")[0] for x in src["lacks"]) or "nothing"
            print(f"log {src['log']}: {len(src['segments'])} segment(s) between {len(src['gaps'])} gap(s) of "
                  f"lost states, {len(src['dropped_segments'])} too short to use; lacks: {lacks} "
                  "(report.json log_sources)")
    names = ", ".join(f"{e['name']}@{e['joint']}" for e in rep["effects"]) or "none"
    print(f"verdict: {rep['verdict']}; effects: {names}; ambiguous: {len(rep['ambiguous'])}")
    print(f"report: {args.out / 'report.json'}  plant: {args.out / 'plant.json'}")
    return 0


def _spine_effects(specs: list[str]):
    """The --effect specs as Effects, parsed before any simulation (a bad spec is bad input)."""
    from sparc_quad.gap.robot import Robot
    from sparc_quad.gap.synth import SPINE_URDF, parse_effect_spec
    from spine_module import params as P

    robot = Robot(SPINE_URDF, P.ACTUATED_JOINTS, {"q1": 0.0}, (0.0, 0.0, -P.GRAVITY_M_S2))
    with bad_input(ValueError, prefix="--effect "):
        return [parse_effect_spec(spec, robot) for spec in specs]


def run_synth(args: argparse.Namespace) -> int:
    periods = args.periods or (2 if args.arm else 4)
    if periods * args.period > SIM_DURATION_MAX_S:
        raise BadInput(f"--periods {periods} x --period {args.period:g} s is {periods * args.period:g} s a "
                       f"trial; a simulated trial is kept in memory, at most {SIM_DURATION_MAX_S:g} s")
    if args.arm:
        if args.effect or args.unmodelled:
            raise BadInput("--effect and --unmodelled are for the spine; --arm hides its own effects")
        return _synth_arm(args, periods)
    if args.joint_side or args.uncoupled or args.no_dq:
        raise BadInput("--joint-side, --uncoupled and --no-dq need --arm")
    from sparc_quad.gap.synth import synth

    effects = _spine_effects(args.effect)
    with atomic_dir(args.out) as tmp:
        res = synth(tmp, effects, seed=args.seed, n_trials=args.trials_n, periods=periods,
                    period_s=args.period, unmodelled=args.unmodelled)
    for pth in moved(res["trials"], tmp, args.out):
        print(pth)
    print(f"hidden effects: {json.dumps([e.to_dict() for e in res['hidden']])}")
    return 0


def _synth_arm(args: argparse.Namespace, periods: int) -> int:
    from sparc_quad.gap.synth_arm import ArmCase, synth_arm

    with atomic_dir(args.out) as tmp:
        res = synth_arm(tmp, seed=args.seed, n_trials=args.trials_n, periods=periods,
                        period_s=args.period, case=ArmCase(coupled_wrist=not args.uncoupled),
                        motor_side=not args.joint_side, with_dq=not args.no_dq)
    for pth in moved(res["trials"], tmp, args.out):
        print(pth)
    print(f"truth: {args.out / 'truth.json'} ({len(res['truth']['hidden'])} hidden effects; "
          "the last trial is the held-out one)")
    return 0


def run_import(args: argparse.Namespace) -> int:
    from sparc_quad.gap.import_util import LogImportError

    out = args.out
    with atomic_dir(out) as tmp, bad_input(LogImportError):
        paths = args.importer.run(argparse.Namespace(**{**vars(args), "out": tmp}))
    for pth in moved(paths, tmp, out):
        print(pth)
    return 0
