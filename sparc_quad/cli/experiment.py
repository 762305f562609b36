"""The bench script options shared by `spine-node --motors inprocess` and `bench-robot` (the robot side's
script: what the stand-in robot commands and which force it applies)."""

from __future__ import annotations

import argparse

from sparc_quad.cli.args import SIM_DURATION_MAX_S, add_gain_options, in_range, seed
from sparc_quad.cli.errors import BadInput, bad_input

AMPLITUDE_MAX_M = 0.1  # a push beyond 0.1 m leaves the spine's workspace along x


def add_experiment_args(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group("bench experiment (the robot side's script)")
    g.add_argument("--experiment", choices=["hold", "static", "ident", "none"], default="hold",
                   help="hold: impedance at x_d with the default gains; static: push-pull along x "
                        "(paper Section IV-A); ident: the identification excitation for `gap run` (sums of "
                        "sines on the task target and a push; 20 s unless --duration; docs/gap.md); none: "
                        "send no spine command")
    add_gain_options(g, ("kx",), prefix="static: commanded ")
    g.add_argument("--amplitude", type=in_range(0.0, AMPLITUDE_MAX_M, lo_open=True), default=0.025,
                   help=f"static: displacement the push aims for, m, up to {AMPLITUDE_MAX_M}")
    g.add_argument("--period", type=in_range(0.0, SIM_DURATION_MAX_S, lo_open=True), default=8.0,
                   help="static: push-pull period, s")
    g.add_argument("--cycles", type=in_range(0.0, 1000.0, lo_open=True), default=1.0,
                   help="static: push-pull cycles (period x cycles is the run's length)")
    g.add_argument("--seed", type=seed, default=0, help="plant noise seed")
    g.add_argument("--ideal-plant", action="store_true", help="plant = model: no quantisation, no noise")


def script(args: argparse.Namespace):
    """The BenchScript the options describe; BadInput if it would run longer than a log can hold."""
    from sparc_quad.experiments.scripts import hold_script, static_push_script
    from sparc_quad.robot_side.scripts import BenchScript

    if args.experiment == "static":
        s = static_push_script(args.kx, args.amplitude, args.period, args.cycles)
    elif args.experiment == "ident":
        from sparc_quad.robot_side.excitation import IDENT_DURATION_S, ident_script

        with bad_input(ValueError, prefix="--experiment ident: "):
            s = ident_script(args.duration if args.duration is not None else IDENT_DURATION_S)
    elif args.experiment == "hold":
        s = hold_script()
    else:
        s = BenchScript()
    if args.duration is not None:
        s.duration_s = args.duration
    if s.duration_s is not None and s.duration_s > SIM_DURATION_MAX_S:
        raise BadInput(f"the bench script would run {s.duration_s:g} s (--period x --cycles or --duration); "
                       f"a simulated run keeps its log in memory, at most {SIM_DURATION_MAX_S:g} s")
    return s


def plant(args: argparse.Namespace):
    from sparc_quad.sim.plant import PlantConfig

    return PlantConfig().ideal() if args.ideal_plant else PlantConfig()
