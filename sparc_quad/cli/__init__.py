"""`sparc-quad` command line: one module per subcommand group, each exposing `register(subparsers)`.

To add a subcommand, write `sparc_quad/cli/<name>.py` with `register(sub)` that adds its parser and sets
`func` (called with the parsed args, returning an exit code), then add the module name to `COMMANDS`.

Command modules import only the robot-side install at module level (argparse, params, the spine module):
simulation, plotting and statistics are imported inside the run functions, so `spine-node --help` starts
without pybullet, matplotlib or scipy, and a command whose extra is not installed says which one to
install (exit 2). A subparser may name its extra with `set_defaults(extra="sim")`.
"""

from __future__ import annotations

import argparse
import importlib
import logging
import sys

COMMANDS: tuple[str, ...] = ("robots", "bench", "demo", "node", "motors", "gap", "bound", "study")

# top-level modules that only an extra installs -> that extra (when the command names none)
EXTRA_OF_MODULE: dict[str, str] = {
    "pybullet": "sim", "pybullet_data": "sim", "example_robot_data": "sim", "tqdm": "sim", "msgpack": "sim",
    "matplotlib": "sim", "scipy": "sim", "statsmodels": "study", "cma": "study", "dask": "study",
    "distributed": "study",
}



def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="sparc-quad",
        description="SPARC spine for quadrupeds. All quantities in SI units: m, rad, s, N, N*m, kg.",
    )
    parser.add_argument("-v", "--verbose", action="count", default=0, help="more log output (-vv: debug)")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for name in COMMANDS:
        importlib.import_module(f"sparc_quad.cli.{name}").register(sub)
    return parser


def missing_extra(exc: ModuleNotFoundError, extra: str | None) -> str | None:
    """The message for a module an extra would install, or None if `exc` is not about such a module."""
    top = (exc.name or "").split(".")[0]
    if top not in EXTRA_OF_MODULE:
        return None
    extra = extra or EXTRA_OF_MODULE[top]
    return f"this command needs the [{extra}] extra (module {top!r} is not installed): " \
           f"pip install 'sparc-quad[{extra}]'"


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    level = logging.WARNING - 10 * min(args.verbose, 2)
    logging.basicConfig(level=level, format="%(asctime)s %(name)s %(levelname)s: %(message)s")
    try:
        return int(args.func(args) or 0)
    except ModuleNotFoundError as exc:
        msg = missing_extra(exc, getattr(args, "extra", None))
        if msg is None:
            raise
        print(f"sparc-quad {args.command}: {msg}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:  # outputs are written atomically (cli.output), so nothing half-written stays
        print(f"sparc-quad {args.command}: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
