"""Per-run fixed CPU cost of `sparc-quad bound --no-plots` (imports, set-up, metrics, CSV), in one run.

Each run is a fresh process (what a sweep of short runs pays per trial); its CPU time (user + sys, from
the child's rusage) is measured at two simulated durations, `--repeat` times each, and the minimum of
each taken. The fixed cost is the intercept of the line through the two minima (CPU s at 0 s simulated),
the slope is the CPU cost per simulated second. Goal: fixed cost < 1 s of CPU.

    python bench/run_cost.py --json out/bench/run_cost.json [--repeat 3] [--short 0.05] [--long 1.0]

`--with-plots` also times the short run with the PNG plots (context: what `--no-plots` saves).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

GOAL_CPU_S = 1.0


def child_cpu_s(duration_s: float, out: Path, plots: bool) -> float:
    """User + sys CPU seconds of one `sparc-quad bound` process."""
    cmd = [sys.executable, "-m", "sparc_quad", "bound", "--duration", str(duration_s), "--out", str(out)]
    if not plots:
        cmd.append("--no-plots")
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    _, status, usage = os.wait4(proc.pid, 0)
    err = proc.stderr.read().decode(errors="replace") if proc.stderr else ""
    proc.returncode = os.waitstatus_to_exitcode(status)
    if proc.returncode not in (0, 1):  # 1: the robot fell, still a complete run
        raise RuntimeError(f"{' '.join(cmd)} exited {proc.returncode}: {err[-500:]}")
    return usage.ru_utime + usage.ru_stime


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--json", type=Path, required=True)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--short", type=float, default=0.05, help="short run, simulated s")
    ap.add_argument("--long", type=float, default=1.0, help="long run, simulated s")
    ap.add_argument("--with-plots", action="store_true", help="also time the short run with plots")
    args = ap.parse_args()
    if args.repeat < 1 or not 0 < args.short < args.long:
        print("run_cost: need --repeat >= 1 and 0 < --short < --long", file=sys.stderr)
        return 2
    runs: dict[str, list[float]] = {"short": [], "long": [], "short_with_plots": []}
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "bound"
        for _ in range(args.repeat):  # interleaved, so a burst of load hits both durations alike
            runs["short"].append(child_cpu_s(args.short, out, plots=False))
            runs["long"].append(child_cpu_s(args.long, out, plots=False))
            if args.with_plots:
                runs["short_with_plots"].append(child_cpu_s(args.short, out, plots=True))
    c_short, c_long = min(runs["short"]), min(runs["long"])
    slope = (c_long - c_short) / (args.long - args.short)
    fixed = c_short - slope * args.short
    load = Path("/proc/loadavg").read_text().split()[:3] if Path("/proc/loadavg").exists() else None
    result = {
        "fixed_cost_cpu_s": fixed,
        "goal_cpu_s": GOAL_CPU_S,
        "fixed_cost_over_goal": fixed / GOAL_CPU_S,
        "cpu_s_per_simulated_s": slope,
        "short_s": args.short,
        "long_s": args.long,
        "repeat": args.repeat,
        "min_cpu_s": {"short": c_short, "long": c_long},
        "short_with_plots_cpu_s": min(runs["short_with_plots"]) if runs["short_with_plots"] else None,
        "all_runs_cpu_s": runs,
        "loadavg": load,
    }
    args.json.parent.mkdir(parents=True, exist_ok=True)
    args.json.write_text(json.dumps(result, indent=2) + "\n")
    print(json.dumps(result, indent=2))
    print(f"fixed cost of bound --no-plots: {fixed:.3f} s CPU = {fixed / GOAL_CPU_S:.2f}x the goal "
          f"(< {GOAL_CPU_S} s); {slope:.3f} s CPU per simulated s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
