"""`sparc-quad` command line: one module per command, each exposing `register(subparsers)`.

To add a command, write `sparc_quad/cli/<name>.py` with `register(sub)` that adds its parser and sets
`func` (called with the parsed args, returning an exit code), then add the module name to `COMMANDS`.

Command modules import only the robot-side install at module level (argparse, params, the spine module):
simulation, plotting and statistics are imported inside the run functions, so `spine-node --help` starts
without pybullet, matplotlib or scipy, and a command whose extra is not installed says which one to
install (exit 2). A subparser may name its extra with `set_defaults(extra="sim")`.

Exit codes: 0 done, 1 the run failed (a fall, a motor that did not answer), the disk is full (one line) or an
internal error (a bug: "internal error", traceback in a log file, see `errors`), 2 bad input (one line
naming it), 130 Ctrl-C.
"""

from __future__ import annotations

import importlib
import logging
import os
import sys

from sparc_quad.cli.errors import BadInput, disk_full, internal_error, report_disk_full
from sparc_quad.cli.parser import Parser

# modules under sparc_quad/cli, one per command (`gap` has subcommands run|synth|import)
COMMANDS: tuple[str, ...] = ("robots", "bench", "demo", "spine_node", "bench_robot", "spine_cmd",
                             "spine_echo", "motors", "gap", "bound", "study")

# top-level modules that only an extra installs -> that extra (when the command names none)
EXTRA_OF_MODULE: dict[str, str] = {
    "pybullet": "sim", "pybullet_data": "sim", "example_robot_data": "sim", "tqdm": "sim", "msgpack": "sim",
    "matplotlib": "sim", "scipy": "sim", "statsmodels": "study", "cma": "study", "dask": "study",
    "distributed": "study",
}


def version() -> str:
    from sparc_quad import __version__

    return __version__


def build_parser() -> Parser:
    parser = Parser(
        prog="sparc-quad",
        description="SPARC spine for quadrupeds. All quantities in SI units: m, rad, s, N, N*m, kg.",
    )
    parser.add_argument("-v", "--verbose", action="count", default=0,
                        help="more log output (-vv: debug); internal errors print their traceback")
    parser.add_argument("--version", action="version", version=f"sparc-quad {version()}")
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


def _interrupted(command: str) -> int:
    print(f"{' '.join(filter(None, ('sparc-quad', command)))}: interrupted", file=sys.stderr)
    return 130


def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    try:  # Ctrl-C while the command modules import (numpy, pinocchio): no traceback either
        from sparc_quad.cli.gap import legacy_argv

        args = build_parser().parse_args(legacy_argv(argv))
    except KeyboardInterrupt:
        return _interrupted("")
    except Exception as exc:  # a command module that does not import or register: a bug
        msg = missing_extra(exc, None) if isinstance(exc, ModuleNotFoundError) else None
        if msg is not None:
            print(f"sparc-quad: {msg}", file=sys.stderr)
            return 2
        return internal_error("", exc, None, "-v" in argv or "--verbose" in argv)
    name = getattr(args, "command_name", args.command)
    level = logging.WARNING - 10 * min(args.verbose, 2)
    logging.basicConfig(level=level, format="%(asctime)s %(name)s %(levelname)s: %(message)s")
    try:
        rc = int(args.func(args) or 0)
    except BadInput as exc:
        print(f"sparc-quad {name}: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:  # outputs are written atomically (cli.output), so nothing half-written stays
        # said below, once the exception and its frames are gone: a progress bar they held closes (and
        # writes its last line) first, so "interrupted" is the last line
        rc = 130
    except ModuleNotFoundError as exc:
        msg = missing_extra(exc, getattr(args, "extra", None))
        if msg is None:
            return internal_error(name, exc, args, args.verbose > 0)
        print(f"sparc-quad {name}: {msg}", file=sys.stderr)
        return 2
    except Exception as exc:
        full = disk_full(exc)
        if full is not None:
            return report_disk_full(name, exc, full, args)
        return internal_error(name, exc, args, args.verbose > 0)
    finally:
        _end_process_requests()
    if rc == 130:  # Ctrl-C: KeyboardInterrupt, or a service stopped cleanly by it (signals.Stop)
        _interrupted(name)
    return rc



def _end_process_requests() -> None:
    """What a command asked of the kernel for its process ends with the command, also when it runs in a
    caller's process (a test, a script calling `main`): the CPU wake-latency request of spine-node and
    bound --lcm (`spine_module.node.realtime`, loaded only by them)."""
    realtime = sys.modules.get("spine_module.node.realtime")
    if realtime is not None:
        realtime.release_wake_latency()


def entry() -> None:
    """The `sparc-quad` program (console script and `python -m sparc_quad`): main(), then exit.

    After Ctrl-C the process ends with os._exit(130): a KeyboardInterrupt that passed through an
    extension's PyRun_String while it imported (seen 1 run in 40 at load 1.6) leaves CPython's
    "unhandled KeyboardInterrupt" flag set, and the interpreter would then kill itself with SIGINT (-2)
    after main() had already cleaned up and returned 130."""
    rc = main()
    if rc == 130:
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(130)
    sys.exit(rc)


if __name__ == "__main__":
    entry()
