"""`sparc-quad demo`: the main job of `make demo`."""

from __future__ import annotations

import argparse
from pathlib import Path

from sparc_quad.cli import bench


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("demo", help="the main job: the paper's three bench experiments, reduced size",
                       description="Runs `bench all --quick` into --out. Units: SI (N/m, N*s/m, m, N, s).")
    p.add_argument("--out", type=Path, default=Path("out/demo"), help="output folder (default: %(default)s)")
    p.add_argument("--full", action="store_true", help="full-size experiments (a few minutes)")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    ns = argparse.Namespace(out=args.out, seed=0, plant=None, ideal_plant=False, quick=not args.full)
    return bench.run_all(ns)
