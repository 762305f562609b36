"""The 20 s stability grid: spine k_x x d_x (k_z, k_theta at their defaults), rigid baseline, speeds.

    python bench/bound_grid.py --json out/bench/bound_grid.json [--duration 20]

Each cell is one deterministic in-process bound (seed 0); prints whether it fell and its mean speed.
"""

from __future__ import annotations

import argparse
import json
from dataclasses import replace
from pathlib import Path

from sparc_quad.bound.run import BoundConfig, run_bound
from sparc_quad.gaits.bound import BoundParams
from sparc_quad.sim.spine_drive import SpineGains
from spine_module import params as P

KX = (300.0, 700.0, 1100.0, 1500.0)
DX = (2.0, 20.0, 40.0)
SPEEDS = (0.3, 0.6, 0.9)


def grid(duration: float) -> list[dict]:
    rows = []
    for speed in SPEEDS:
        gait = replace(BoundParams(), speed_m_s=speed)
        cells = [("rigid", None, None)] + [("impedance", kx, dx) for kx in KX for dx in DX]
        for kind, kx, dx in cells:
            k = (kx or P.K_DEFAULT[0], P.K_DEFAULT[1], P.K_DEFAULT[2])
            d = (dx or P.D_DEFAULT[0], P.D_DEFAULT[1], P.D_DEFAULT[2])
            cfg = BoundConfig(duration_s=duration, gait=gait, spine=SpineGains(k=k, d=d),
                              spine_variant="rigid" if kind == "rigid" else "impedance")
            m = run_bound(cfg).metrics
            row = {"spine": kind, "k_x": kx, "d_x": dx, "target_speed": speed, "fell": m["fell"],
                   "fall_time_s": m["fall_time_s"], "speed_m_s": m.get("speed_m_s"),
                   "cot_abs_total": m.get("cot_abs_total"),
                   "peak_spine_torque_nm": m.get("peak_spine_torque_nm")}
            print(json.dumps(row), flush=True)
            rows.append(row)
    return rows


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--json", type=Path, required=True)
    ap.add_argument("--duration", type=float, default=20.0)
    args = ap.parse_args()
    rows = grid(args.duration)
    args.json.parent.mkdir(parents=True, exist_ok=True)
    summary = {"duration_s": args.duration, "cells": len(rows), "falls": sum(r["fell"] for r in rows),
               "rows": rows}
    args.json.write_text(json.dumps(summary, indent=2) + "\n")
    print(f"{summary['falls']} falls in {len(rows)} cells of {args.duration} s")
    return 1 if summary["falls"] else 0


if __name__ == "__main__":
    raise SystemExit(main())
