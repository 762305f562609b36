"""Gait A (the authors' open-loop sine bound) on the Solo12 host: does it bound? A grid over the joint PD,
the foot ellipse, the frequency and the ellipse's direction, impedance spine with the authors' schedule.

    python bench/sine_grid.py --json out/bench/sine_grid.json [--duration 6]

Each cell is one deterministic bound (seed 0) stopped at its first fall; prints fall time and speed.
"""

from __future__ import annotations

import argparse
import itertools
import json
import warnings
from pathlib import Path

from sparc_quad.study.trial import run_trial

KP = (8.0, 14.0)  # N*m/rad (the authors: 8)
KD = (0.1, 0.3)  # N*m*s/rad (the authors: 0.1)
L = (0.04, 0.08, 0.12)  # m (the authors: 0.12)
H = (0.03, 0.06)  # m (the authors: 0.06)
F = (2.5, 3.1, 4.0)  # Hz (the authors: 3.1)
DIRECTION = (1.0, -1.0)  # +1: the authors' code literally


def grid(duration: float) -> list[dict]:
    from dataclasses import replace

    from sparc_quad.bound.run import run_bound
    from sparc_quad.study.trial import config_of as bound_config

    rows = []
    for kp, kd, step, height, f, direction in itertools.product(KP, KD, L, H, F, DIRECTION):
        cfg = bound_config({"gait": "sine", "spine": "impedance", "duration": duration, "frequency": f,
                            "step_length": step, "step_height": height, "direction": direction})
        cfg = replace(cfg, gait=replace(cfg.gait, kp_nm_rad=kp, kd_nm_s_rad=kd), stop_on_fall=True)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            r = run_bound(cfg)
        m = r.metrics
        row = {"kp": kp, "kd": kd, "step_length_m": step, "step_height_m": height, "frequency_hz": f,
               "direction": direction, "fell": m["fell"], "fall_time_s": m["fall_time_s"],
               "fall_reason": m["fall_reason"], "x_end_m": float(r.column("x")[-1]),
               "speed_m_s": m.get("speed_m_s")}
        print(json.dumps(row), flush=True)
        rows.append(row)
    return rows


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--json", type=Path, required=True)
    ap.add_argument("--duration", type=float, default=6.0)
    args = ap.parse_args()
    rows = grid(args.duration)
    fwd = [r for r in rows if r["direction"] > 0]
    summary = {"duration_s": args.duration, "cells": len(rows), "falls": sum(r["fell"] for r in rows),
               "literal_port_cells": len(fwd), "literal_port_falls": sum(r["fell"] for r in fwd),
               "rows": rows, "run_trial": run_trial.__module__}
    args.json.parent.mkdir(parents=True, exist_ok=True)
    args.json.write_text(json.dumps(summary, indent=2) + "\n")
    print(f"{summary['falls']} falls in {len(rows)} cells of {args.duration} s "
          f"({summary['literal_port_falls']} of {len(fwd)} with the authors' ellipse direction)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
