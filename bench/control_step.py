"""Cost of one control step against one raw pinocchio RNEA call on the same model, in the same run.

Prints and writes (--json) median wall times and ratios: impedance step (eq. 3 + eq. 4), impedance
without friction compensation, task PD step (eq. 5) on the default backend (the numba-compiled kernel
where numba works), the same steps on the pinocchio reference path, kinematics update, and
`pinocchio.rnea`. Goal: impedance and PD steps at most 3x one rnea.
Medians over repeated batches of this thread's CPU time (--clock wall for wall time) make the ratio
robust to a shared, noisy machine.
"""

from __future__ import annotations

import argparse
import statistics
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pinocchio as pin
from bench_io import emit, host_facts

from spine_module import params as P
from spine_module.control import ImpedanceController, StribeckFriction, TaskPDController
from spine_module.model import SpineModel

CLOCKS = {"cpu": time.thread_time, "wall": time.perf_counter}
clock = time.thread_time


def median_us(fn: Callable[[], object], batches: int, per_batch: int) -> float:
    times = []
    for _ in range(batches):
        t0 = clock()
        for _ in range(per_batch):
            fn()
        times.append((clock() - t0) / per_batch)
    return 1e6 * statistics.median(times)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--json", type=Path, help="write the results here")
    ap.add_argument("--batches", type=int, default=30)
    ap.add_argument("--per-batch", type=int, default=2000)
    ap.add_argument("--clock", choices=tuple(CLOCKS), default="cpu",
                    help="cpu: this thread's CPU time (robust on a shared machine, the default); wall")
    args = ap.parse_args()
    global clock
    clock = CLOCKS[args.clock]
    if args.batches < 1 or args.per_batch < 1:
        ap.error("--batches and --per-batch must be at least 1")

    model = SpineModel()
    rng = np.random.default_rng(0)
    q = P.Q_EQUILIBRIUM + rng.uniform(-0.1, 0.1, 4)
    dq = rng.normal(0.0, 0.5, 4)
    a = rng.normal(0.0, 1.0, 4)
    raw = model.model.createData()
    imp = ImpedanceController(model, friction=StribeckFriction.nominal())
    imp_nf = ImpedanceController(model, friction=None)
    pd = TaskPDController(model)
    imp_ref = ImpedanceController(model, friction=StribeckFriction.nominal(), backend="pinocchio")
    pd_ref = TaskPDController(model, backend="pinocchio")
    kin = model.create_data()
    cases = {
        "rnea_us": lambda: pin.rnea(model.model, raw, q, dq, a),
        "impedance_step_us": lambda: imp.step(q, dq, 0.0),
        "impedance_no_friction_step_us": lambda: imp_nf.step(q, dq, 0.0),
        "pd_step_us": lambda: pd.step(q, dq),
        "impedance_pinocchio_step_us": lambda: imp_ref.step(q, dq, 0.0),
        "pd_pinocchio_step_us": lambda: pd_ref.step(q, dq),
        "kinematics_us": lambda: model.update_kinematics(kin, q, dq),
    }
    for fn in cases.values():  # warm up
        fn()
    # interleave the cases batch by batch so load changes hit them alike
    samples: dict[str, list[float]] = {k: [] for k in cases}
    for _ in range(args.batches):
        for name, fn in cases.items():
            samples[name].append(median_us(fn, 1, args.per_batch))
    result = {k: statistics.median(v) for k, v in samples.items()}
    rnea = result["rnea_us"]
    result.update({
        "impedance_over_rnea": result["impedance_step_us"] / rnea,
        "impedance_no_friction_over_rnea": result["impedance_no_friction_step_us"] / rnea,
        "pd_over_rnea": result["pd_step_us"] / rnea,
        "impedance_pinocchio_over_rnea": result["impedance_pinocchio_step_us"] / rnea,
        "pd_pinocchio_over_rnea": result["pd_pinocchio_step_us"] / rnea,
        "goal_impedance_over_rnea": 3.0,
        "goal_pd_over_rnea": 3.0,
        "backend": imp.backend,
        "clock": args.clock,
        **host_facts(),
    })
    emit(result, args.json, width=34)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
