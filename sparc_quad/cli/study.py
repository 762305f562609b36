"""`sparc-quad study run|report`: spine-stiffness studies over a grid of bound trials."""

from __future__ import annotations

import argparse
import math
import signal
import sys
from pathlib import Path

from sparc_quad.cli.args import existing_dir, in_range, output_dir
from sparc_quad.cli.errors import BadInput

WORKERS_MAX = 256
BOOTSTRAP_MAX = 100_000  # draws per seed; the report holds them all in memory
SCHEDULER_SCHEMES = ("tcp", "tls", "inproc", "ucx", "ws", "wss")


def _spec_file(text: str) -> Path:
    """A study spec: an existing UTF-8 text file (the TOML itself is checked by study.spec)."""
    path = Path(text)
    try:
        path.read_bytes().decode("utf-8")
    except OSError as exc:
        raise argparse.ArgumentTypeError(f"{path}: cannot read ({exc.strerror or exc})") from None
    except UnicodeDecodeError:
        raise argparse.ArgumentTypeError(f"{path}: not a text file (a TOML spec is UTF-8 text)") from None
    return path


def _scheduler(text: str) -> str:
    """A Dask scheduler address: SCHEME://HOST:PORT (e.g. tcp://10.0.0.5:8786) or HOST:PORT."""
    scheme, sep, rest = text.rpartition("://") if "://" in text else ("tcp", "", text)
    host, colon, port = rest.rpartition(":")
    if (sep and scheme not in SCHEDULER_SCHEMES) or not colon or not host or not port.isdigit() \
            or not 0 < int(port) < 65536:
        raise argparse.ArgumentTypeError(
            f"expected a Dask scheduler address SCHEME://HOST:PORT ({', '.join(SCHEDULER_SCHEMES)}), "
            f"e.g. tcp://10.0.0.5:8786, got {text!r}")
    return text


CONFIRM_HOURS = 2.0  # a study estimated longer than this asks for --yes
# simulated s per CPU s of one trial, measured: 10 s bounds take 1.0-2.1 s of CPU on the 2-vCPU hosts here
# (tests/integration/test_hosts_bound.py --durations); the slower engine and gait counted
SIM_S_PER_CPU_S = 5.0


def estimate_hours(spec, workers: int | None) -> float:
    """Wall hours of a spec's trials (counted before expansion, `Spec.size`) on `workers` processes, at the
    longest duration it asks for; raibert-opt counts its search's evaluations per cell, a matched-speed
    study its calibration (at most match_seeds x match_iterations trials per cell)."""
    from sparc_quad.study.executors import default_workers

    def values(key: str, default):
        v = spec.grid.get(key, (spec.base.get(key, default),))
        return [x for x in v if isinstance(x, int | float) and not isinstance(x, bool)] or [default]

    per_trial = max(values("duration", 10.0))
    if "raibert-opt" in values("gait", "raibert") or "raibert-opt" in (spec.base.get("gait"),
                                                                       *spec.grid.get("gait", ())):
        per_trial += math.prod(max(values(k, d)) for k, d in (("popsize", 6), ("iterations", 5),
                                                               ("opt_restarts", 2), ("opt_trial_seeds", 2),
                                                               ("opt_duration", 6.0)))
    if "match_speed" in spec.base or "match_speed" in spec.grid:  # each cell's calibration, once per cell
        from sparc_quad.study.speed_match import DEFAULTS

        cal = max(values("match_seeds", DEFAULTS["match_seeds"])) * max(
            values("match_iterations", DEFAULTS["match_iterations"]))
        per_trial += cal * max(values("duration", 10.0)) / len(spec.seeds)
    cpu_s = spec.size() * per_trial / SIM_S_PER_CPU_S
    return cpu_s / max(1, workers or default_workers()) / 3600.0


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "study",
        help="run and report spine-stiffness studies (grids of bound trials)",
        description="Studies: a TOML spec ([study] name, seeds; [scenario] the base run: any "
        "`sparc-quad bound` option in snake_case, one value each; [grid] the same keys with lists of values) "
        "expanded into trials, each the base scenario with one cell's values on top, each stored as one "
        "record with its resolved scenario (`sparc-quad bound --scenario RECORD` re-runs it); reruns "
        "execute only missing trials.",
    )
    ssub = p.add_subparsers(dest="study_command", metavar="ACTION", required=True)
    r = ssub.add_parser(
        "run",
        help="execute the missing trials of a spec into DIR",
        description="Execute every trial of SPEC whose record is missing in DIR/trials; write "
        "DIR/trials.csv and DIR/summary.json. Exit 0 if all trials succeeded, 1 if any "
        "failed (their errors are in the records), 2 on bad input, 130 on Ctrl-C.",
    )
    r.add_argument("spec", type=_spec_file, metavar="SPEC.toml", help="study spec")
    r.add_argument("--out", type=output_dir, required=True, metavar="DIR",
                   help="study folder (created; resumable)")
    r.add_argument("--workers", type=in_range(1, WORKERS_MAX, kind=int), default=None,
                   help=f"local worker processes, up to {WORKERS_MAX} (default: one per core)")
    r.add_argument(
        "--scheduler",
        type=_scheduler,
        default=None,
        metavar="ADDRESS",
        help="run on an existing Dask distributed cluster, e.g. tcp://host:8786 (needs the [study] extra)",
    )
    r.add_argument("--scheduler-timeout", type=in_range(1.0, 3600.0), default=30.0, metavar="S",
                   help="--scheduler: give up (exit 2) when the scheduler has not answered within this "
                        "many s")
    r.add_argument("--yes", action="store_true",
                   help=f"run a study estimated to take longer than {CONFIRM_HOURS:g} h without asking "
                        "(the estimate is printed either way)")
    r.add_argument("--retry-failed", action="store_true", help="run again the trials recorded as failed")
    r.add_argument("--no-progress", action="store_true", help="no progress bar")
    r.add_argument("--report", action="store_true", help="write the report when the run ends")
    r.set_defaults(func=run)
    rep = ssub.add_parser(
        "report",
        help="statistics and plots of a study folder",
        description="Per panel: heatmaps of CoT over k x d against each spine's baseline (t intervals "
        "over seeds, block bootstrap over strides), CoT against k per d, cost against speed, fall rates, "
        "the claims' verdicts. "
        "Writes DIR/report/ (PNG, cells.csv, cells.json).",
    )
    rep.add_argument(
        "dir",
        type=existing_dir("a folder written by `study run`"),
        nargs="+",
        metavar="DIR",
        help="folder(s) written by `study run`; several are reported as one study (then --out is required)",
    )
    rep.add_argument(
        "--out",
        type=output_dir,
        default=None,
        metavar="REPORT_DIR",
        help="where to write the report (default: DIR/report)",
    )
    rep.add_argument("--bootstrap", type=in_range(1, BOOTSTRAP_MAX, kind=int), default=400,
                     help=f"block-bootstrap draws per seed for the within-seed variance, up to "
                          f"{BOOTSTRAP_MAX}")
    rep.set_defaults(func=report)


def run(args: argparse.Namespace) -> int:
    from sparc_quad.study.executors import ExecutorUnavailable
    from sparc_quad.study.runner import StudyWriteError, run_study
    from sparc_quad.study.spec import SpecError, load_spec

    try:
        sized = load_spec(args.spec, check=False)  # sized before it is built
        size, hours = sized.size(), estimate_hours(sized, args.workers)
        if hours > CONFIRM_HOURS and not args.yes:
            raise BadInput(f"{size} trials, about {hours:.1f} h with {args.workers or 'one worker per core'} "
                           f"(at {SIM_S_PER_CPU_S:g} simulated s per CPU s); add --yes to run it")
        if hours > 0.1:
            print(f"{size} trials, about {hours:.1f} h", file=sys.stderr)
        spec = load_spec(args.spec)
    except SpecError as exc:
        raise BadInput(str(exc)) from exc
    if args.scheduler and args.workers:
        raise BadInput("--workers is for the local pool; a Dask cluster has its own workers")
    if args.scheduler:
        try:
            import dask.distributed  # noqa: F401
        except ImportError:
            raise BadInput("--scheduler needs Dask distributed: pip install 'sparc-quad[study]'") from None

    def interrupt(signum, frame):
        raise KeyboardInterrupt

    signal.signal(signal.SIGTERM, interrupt)  # a terminated study also leaves its tables consistent
    try:
        s = run_study(
            spec,
            args.out,
            workers=args.workers,
            scheduler=args.scheduler,
            retry_failed=args.retry_failed,
            progress=not args.no_progress,
            scheduler_timeout_s=args.scheduler_timeout,
        )
    except ExecutorUnavailable as exc:
        raise BadInput(str(exc)) from exc
    except StudyWriteError as exc:
        print(f"sparc-quad study run: error: {exc.strerror}; the finished records are whole, rerun to "
              "resume", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print(
            f"interrupted; finished trials are kept in {args.out}/trials (rerun to resume)", file=sys.stderr
        )
        return 130
    print(
        f"{s.trials} trials: executed {s.executed}, cached {s.cached}, failed {s.failed}; "
        f"{args.out / 'trials.csv'}"
    )
    if args.report:
        rc = _report(args.out, 400)
        if rc:
            return rc
    return 1 if s.failed else 0


def _report(folder: Path | list[Path], n_boot: int, out: Path | None = None) -> int:
    from sparc_quad.study.report import ReportError, write_report

    try:
        paths = write_report(folder, n_boot=n_boot, out=out)
    except ReportError as exc:
        raise BadInput(str(exc)) from exc
    for p in paths:
        print(f"wrote {p}")
    return 0


def report(args: argparse.Namespace) -> int:
    if len(args.dir) > 1 and args.out is None:
        raise BadInput("several study folders need --out REPORT_DIR")
    return _report(args.dir, args.bootstrap, args.out)
