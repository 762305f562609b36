"""Cost of the robot side's one loop in the bench rig: `bench.rig.run` (RobotSide + BenchBody +
DirectPort: torso/feedback messages, frame clipping, motor model, log) against the bare loop it replaced
(controller on the world's measured state, step), same trial, same run.

    python bench/rig_loop.py --json out/bench/rig_loop.json [--seconds 2] [--repeat 3]

Prints both per-tick wall times (best of --repeat) and their ratio; both produce the same trajectory
(checked here, to 1e-12).
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

from sparc_quad.experiments import rig
from sparc_quad.experiments.static import StaticConfig
from sparc_quad.sim.bench_world import BenchWorld
from sparc_quad.sim.forces import push_pull
from spine_module import params as P
from spine_module.model import SpineModel


def bare(controller, n: int, force) -> np.ndarray:
    """The pre-robot-side rig: measured state -> controller -> force -> step (no messages, no log)."""
    kin = controller.model.create_data()
    f_ext = np.zeros(3)
    x = np.zeros((n, 3))
    with BenchWorld() as world:
        for i in range(n):
            q, dq = world.measured_joint_state()
            out = controller.step(q, dq)
            st = world.state()
            controller.model.update_kinematics(kin, st.q, st.dq)
            fx = force(world.time_s, kin.x, kin.dx)
            f_ext[0] = fx
            world.load_cell(fx)
            x[i] = kin.x
            world.step(out.tau, f_ext if fx != 0.0 else None)
    return x


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=2.0)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--json", type=Path)
    a = ap.parse_args()
    cfg = StaticConfig()
    n = round(a.seconds / P.CONTROL_PERIOD_S)
    force = push_pull(500.0 * cfg.amplitude_m, 1.0)
    model = SpineModel()
    best = {"bare": np.inf, "robot_side": np.inf}
    for _ in range(a.repeat):
        ctrl = rig.make_controller("impedance", model, (500.0, cfg.k_z, cfg.k_theta), cfg.d)
        t0 = time.perf_counter()
        x_bare = bare(ctrl, n, force)
        best["bare"] = min(best["bare"], (time.perf_counter() - t0) / n)
        ctrl = rig.make_controller("impedance", model, (500.0, cfg.k_z, cfg.k_theta), cfg.d)
        t0 = time.perf_counter()
        log = rig.run(ctrl, a.seconds, force)
        best["robot_side"] = min(best["robot_side"], (time.perf_counter() - t0) / n)
        assert np.max(np.abs(log.x_true - x_bare)) <= 1e-12, "the two loops disagree"
    out = {"ticks": n, "bare_us_per_tick": 1e6 * best["bare"],
           "robot_side_us_per_tick": 1e6 * best["robot_side"],
           "ratio_robot_side_to_bare": best["robot_side"] / best["bare"]}
    print(json.dumps(out, indent=2))
    if a.json is not None:
        a.json.parent.mkdir(parents=True, exist_ok=True)
        a.json.write_text(json.dumps(out, indent=2))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
