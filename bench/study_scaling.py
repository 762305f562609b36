"""Study throughput: trials per minute with 2 local workers against 1 (goal >= 1.8x on 2 idle cores).

    python bench/study_scaling.py --json out/bench/study_scaling.json [--trials 12] [--duration 6]

Runs the same small study (raibert bound, impedance spine over a k_x list, `--duration` simulated s per
trial) twice from empty folders, with `--workers 1` and `--workers 2`, through `run_study` (process pool
start-up included), and prints both rates and their ratio. The load average is printed beside them: on a
shared machine the ratio measures the cores that were free, not the code.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from sparc_quad.study.runner import run_study
from sparc_quad.study.spec import parse_spec

GOAL = 1.8


def spec(trials: int, duration: float):
    ks = [300.0 + 100.0 * i for i in range(trials)]
    return parse_spec(
        {
            "study": {"name": "scaling", "seeds": [0]},
            "scenario": {"gait": "raibert", "duration": duration, "speed": 0.9},
            "grid": {"spine": ["impedance"], "kx": ks},
        }
    )


def rate(workers: int, trials: int, duration: float) -> dict:
    with tempfile.TemporaryDirectory() as d:
        load0 = os.getloadavg()[0]
        t0 = time.perf_counter()
        s = run_study(spec(trials, duration), Path(d), workers=workers, progress=False)
        wall = time.perf_counter() - t0
    if s.failed or s.executed != trials:
        raise RuntimeError(f"{workers} workers: executed {s.executed}, failed {s.failed} of {trials}")
    return {
        "workers": workers,
        "trials": trials,
        "wall_s": round(wall, 3),
        "trials_per_minute": round(60.0 * trials / wall, 3),
        "load_before": round(load0, 2),
        "load_after": round(os.getloadavg()[0], 2),
    }


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--json", type=Path, default=None, help="write the results here")
    ap.add_argument("--trials", type=int, default=12, help="trials per run (default %(default)s)")
    ap.add_argument("--duration", type=float, default=6.0, help="simulated s per trial (default %(default)s)")
    args = ap.parse_args(argv)
    if args.trials < 2 or args.duration <= 0:
        print("error: --trials must be >= 2 and --duration > 0", file=sys.stderr)
        return 2
    one = rate(1, args.trials, args.duration)
    two = rate(2, args.trials, args.duration)
    ratio = two["trials_per_minute"] / one["trials_per_minute"]
    out = {
        "cpu_count": os.cpu_count(),
        "one_worker": one,
        "two_workers": two,
        "speedup_2_over_1": round(ratio, 3),
        "goal": GOAL,
        "speedup_over_goal": round(ratio / GOAL, 3),
    }
    print(json.dumps(out, indent=2))
    if args.json:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps(out, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
