"""`sparc-quad robots`: (re)generate the committed URDFs from the parameter modules."""

from __future__ import annotations

import argparse
from pathlib import Path

from sparc_quad.cli.errors import BadInput
from sparc_quad.robots import ROBOTS_DIR


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("robots", help="generate the URDFs under robots/ from the parameter modules")
    p.add_argument("action", choices=["generate", "check"],
                   help="generate: write the files; check: exit 1 if a committed file differs")
    p.add_argument("--dir", type=Path, default=ROBOTS_DIR, help="robots folder")
    p.set_defaults(func=run, extra="sim")


def run(args: argparse.Namespace) -> int:
    from sparc_quad.sim.robot_files import generate_all

    stale = []
    for path, text in generate_all(args.dir).items():
        current = path.read_text() if path.exists() else None
        if current != text:
            stale.append(path)
            if args.action == "generate":
                try:
                    path.parent.mkdir(parents=True, exist_ok=True)
                    path.write_text(text)
                except OSError as exc:
                    raise BadInput(f"--dir {args.dir}: cannot write {path} ({exc.strerror or exc})") from exc
    verb = "wrote" if args.action == "generate" else "differs"
    for path in stale:
        print(f"{verb}: {path}")
    return 1 if (stale and args.action == "check") else 0
