"""The four spine variants side by side on the Raibert bound: one trial each through the study's
`run_trial` (0.9 m/s, 10 s, seed 0, k_x 800 N/m, d_x 8 N*s/m, other gains at their defaults).

    python bench/spine_variants.py --json out/bench/spine_variants.json [--speed 0.9] [--duration 10]
"""

from __future__ import annotations

import argparse
import json
import warnings
from pathlib import Path

from sparc_quad.study.trial import run_trial

KEYS = ("fell", "speed_m_s", "cot_pos_total", "cot_pos_legs", "cot_pos_spine", "cot_abs_total",
        "cot_net_total", "cot_elec_total", "stride_length_m", "spine_x_amplitude_m", "spine_x_dominant_hz",
        "spine_work_per_stride_j", "peak_spine_torque_nm", "spine_torque_rms_nm", "n_strides")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--json", type=Path, required=True)
    ap.add_argument("--speed", type=float, default=0.9)
    ap.add_argument("--duration", type=float, default=10.0)
    args = ap.parse_args()
    rows = []
    for spine in ("rigid", "rigid-impedance", "impedance", "passive"):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            m = run_trial({"gait": "raibert", "spine": spine, "duration": args.duration, "seed": 0,
                           "speed": args.speed, "kx": 800.0, "dx": 8.0})
        row = {"spine": spine, **{k: m[k] for k in KEYS}}
        print(json.dumps(row), flush=True)
        rows.append(row)
    args.json.parent.mkdir(parents=True, exist_ok=True)
    args.json.write_text(json.dumps({"speed_m_s": args.speed, "duration_s": args.duration, "rows": rows},
                                    indent=2) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
