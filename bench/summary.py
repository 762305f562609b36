"""Each performance ratio beside its goal, from the JSON files `make bench` wrote.

usage: python bench/summary.py [DIR]   (default out/bench; a missing file is reported as not run)
"""

from __future__ import annotations

import json
import os
import sys
from collections.abc import Callable
from pathlib import Path

from bench_io import cpu_model

# (file, label, value from the JSON, goal text, met?)
Row = tuple[str, str, Callable[[dict], float | None], str, Callable[[float], bool]]
ROWS: list[Row] = [
    ("control_step", "impedance step / rnea", lambda r: r["impedance_over_rnea"], "<= 3", lambda v: v <= 3.0),
    ("control_step", "PD step / rnea", lambda r: r["pd_over_rnea"], "<= 3", lambda v: v <= 3.0),
    ("node_tick", "node tick / rnea (CPU time)", lambda r: r["node_tick_over_rnea"], "<= 50",
     lambda v: v <= 50.0),
    ("can_loop", "CAN paced loop rate / 1 kHz, 3 motors", lambda r: r["paced"]["rate_ratio"], "0.99..1.01",
     lambda v: 0.99 <= v <= 1.01),
    ("can_loop", "  host ceiling: same clock, no bus, same CPU",
     lambda r: r["paced"]["host_ceiling"]["rate_ratio"], "(context)", lambda v: True),
    ("can_loop", "highest loop rate under 80 % bus load, Hz",
     lambda r: r["max_rate_hz_for_3_motors_at_80pct"], "(reported)", lambda v: True),
    ("lcm_loop", "LCM lockstep bound / in-process bound (speed)",
     lambda r: r["lcm_lockstep_over_in_process"], ">= 0.5", lambda v: v >= 0.5),
    ("cosim", "bound: physics time / loop time", lambda r: r["in_process_vs_physics_only"], ">= 0.5",
     lambda v: v >= 0.5),
    ("run_cost", "bound --no-plots fixed cost, CPU s", lambda r: r["fixed_cost_cpu_s"], "< 1",
     lambda v: v < 1.0),
    ("engines", "spined dog MuJoCo bound, sim s per CPU s", lambda r: r["mujoco"]["loop_sim_s_per_cpu_s"],
     ">= 20", lambda v: v >= 20.0),
    ("engines", "  its physics (mj_step) share of the loop", lambda r: r["mujoco"]["physics_share"], ">= 0.5",
     lambda v: v >= 0.5),
    ("engines", "  pybullet, same trial, sim s per CPU s", lambda r: r["pybullet"]["loop_sim_s_per_cpu_s"],
     "(context)", lambda v: True),
]


def main(argv: list[str]) -> int:
    folder = Path(argv[0]) if argv else Path("out/bench")
    print(f"{'measure':46s} {'measured':>10s}  {'goal':>11s}  met")
    for name, label, get, goal, ok in ROWS:
        path = folder / f"{name}.json"
        try:
            value = get(json.loads(path.read_text()))
        except FileNotFoundError:
            print(f"{label:46s} {'not run':>10s}  {goal:>11s}  -")
            continue
        except (KeyError, TypeError, ValueError, ZeroDivisionError) as exc:
            print(f"{label:46s} {'n/a':>10s}  {goal:>11s}  - ({type(exc).__name__}: {exc})")
            continue
        if value is None:
            print(f"{label:46s} {'n/a':>10s}  {goal:>11s}  -")
            continue
        met = "" if goal.startswith("(") else ("yes" if ok(value) else "NO")
        print(f"{label:46s} {value:10.3f}  {goal:>11s}  {met}")
    load = Path("/proc/loadavg")
    if load.exists():
        now = " ".join(load.read_text().split()[:3])
        print(f"load average now: {now} ({os.cpu_count()} CPUs: {cpu_model()})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
