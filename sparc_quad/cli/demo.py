"""`sparc-quad demo`, the main job of `make demo`: a short bound with the spine, then the bench runs."""

from __future__ import annotations

import argparse
from pathlib import Path

from sparc_quad.cli import bench
from sparc_quad.cli.args import output_dir


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("demo", help="the main job: a 5 s bound with a compliant spine, then the paper's "
                       "three bench experiments (reduced size)",
                       description="Runs `bound --duration 5` into OUT/bound and `bench all --quick` into "
                       "OUT/bench. Units: SI (spine k_x 500 N/m, d_x 20 N*s/m; m, N, s).")
    p.add_argument("--out", type=output_dir, default=Path("out/demo"), help="output folder")
    p.add_argument("--full", action="store_true", help="20 s bound and full-size experiments (minutes)")
    p.set_defaults(func=run, extra="sim")


def run(args: argparse.Namespace) -> int:
    from sparc_quad.cli import build_parser  # the same defaults a user gets from `sparc-quad bound`

    duration = "20" if args.full else "5"
    bound_args = build_parser().parse_args(["bound", "--duration", duration,
                                            "--out", str(args.out / "bound")])
    rc = bound_args.func(bound_args)
    if rc:
        return rc
    ns = argparse.Namespace(out=args.out / "bench", seed=0, plant=None, ideal_plant=False,
                            quick=not args.full)
    return bench.run_all(ns)
