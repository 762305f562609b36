"""`sparc-quad robots`: the host robots: list them, check a host file, (re)generate the committed files."""

from __future__ import annotations

import argparse
from pathlib import Path

from sparc_quad.cli.errors import BadInput
from sparc_quad.robots import ROBOTS_DIR


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("robots", help="list the host robots, check a host file, generate the robot files",
                       description="list: the listed hosts (a host.toml in each folder of robots/) and their "
                       "defaults. check FILE: every problem of a host file, one line each (keys, URDF, legs, "
                       "standing pose, defaults), exit 1 if any; check: exit 1 if a committed generated file "
                       "differs from its generator. generate: write the generated files (URDF, metadata, "
                       "MJCF) of every listed host. docs/hosts.md walks a new robot through.")
    p.add_argument("action", choices=["list", "check", "generate"],
                   help="list the hosts; check a host file (or the committed files); generate the files")
    p.add_argument("host_file", nargs="?", type=Path, default=None, metavar="HOST_TOML",
                   help="check: the host file to check (default: check the committed files)")
    p.add_argument("--dir", type=Path, default=ROBOTS_DIR, help="robots folder (default: %(default)s)")
    p.set_defaults(func=run, extra="sim")


def run(args: argparse.Namespace) -> int:
    if args.host_file is not None and args.action != "check":
        raise BadInput(f"robots {args.action}: takes no host file (only `robots check HOST_TOML`)")
    if args.action == "list":
        from sparc_quad.sim.hosts import listed_hosts

        for name, host in listed_hosts(args.dir).items():
            defaults = "; ".join(f"{g}: " + ", ".join(f"{k} {v}" for k, v in keys.items())
                                 for g, keys in host.defaults.items())
            print(f"{name:12s} {host.description}{f'  (defaults {defaults})' if defaults else ''}")
        return 0
    if args.action == "check" and args.host_file is not None:
        from sparc_quad.scenario.hosts import check_host

        problems = check_host(args.host_file)
        for line in problems:
            print(f"{args.host_file}: {line}")
        if not problems:
            print(f"{args.host_file}: ok")
        return 1 if problems else 0
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
