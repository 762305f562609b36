"""`sparc-quad` command line: one module per subcommand group, each exposing `register(subparsers)`.

To add a subcommand, write `sparc_quad/cli/<name>.py` with `register(sub)` that adds its parser and sets
`func` (called with the parsed args, returning an exit code), then add the module name to `COMMANDS`.
"""

from __future__ import annotations

import argparse
import importlib
import logging
import sys

COMMANDS: tuple[str, ...] = ("robots", "bench", "demo", "node", "motors", "gap", "bound", "study")


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


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    level = logging.WARNING - 10 * min(args.verbose, 2)
    logging.basicConfig(level=level, format="%(asctime)s %(name)s %(levelname)s: %(message)s")
    return int(args.func(args) or 0)


if __name__ == "__main__":
    sys.exit(main())
