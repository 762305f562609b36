"""CSV reader speed: 301k rows x 6 joints (t, q, dq, tau_cmd: 19 columns), the size of a 60 s 5 kHz log.

    python bench/gap_reader.py --json out/bench/gap_reader.json

Times `sparc_quad.gap.trial.read_csv` (one np.loadtxt call) against the previous reader's row loop
(csv.reader + float per field, measured in the same run) and prints the ratio.
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from sparc_quad.gap.trial import read_csv

ROWS = 301_000


def row_loop(path: Path) -> np.ndarray:
    """The reader before the vectorised one: a Python loop over rows and fields."""
    with path.open(newline="") as fh:
        reader = csv.reader(fh)
        header = next(reader)
        rows = list(reader)
    data = np.empty((len(rows), len(header)))
    for r, row in enumerate(rows):
        for c, text in enumerate(row):
            v = float(text)
            if not np.isfinite(v):
                raise ValueError
            data[r, c] = v
    return data


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--json", type=Path, default=None, help="write the results here")
    args = ap.parse_args(argv)
    rng = np.random.default_rng(0)
    cols = ["t", *(f"{k}_j{i}" for k in ("q", "dq", "tau_cmd") for i in range(1, 7))]
    arr = np.column_stack([np.arange(ROWS) / 5000.0, rng.normal(size=(ROWS, 18))])
    with tempfile.TemporaryDirectory() as d:
        p = Path(d) / "big.csv"
        np.savetxt(p, arr, delimiter=",", header=",".join(cols), comments="", fmt="%.9g")
        t0 = time.perf_counter()
        _, a = read_csv(p)
        t1 = time.perf_counter()
        b = row_loop(p)
        t2 = time.perf_counter()
    assert np.array_equal(a, b)
    out = {"rows": ROWS, "columns": len(cols), "cpu_count": os.cpu_count(),
           "load_avg_1min": os.getloadavg()[0],
           "read_csv_s": round(t1 - t0, 3), "row_loop_s": round(t2 - t1, 3),
           "speedup": round((t2 - t1) / (t1 - t0), 2)}
    print(json.dumps(out, indent=2))
    if args.json:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps(out, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
