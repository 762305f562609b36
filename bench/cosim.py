"""Wall time of a 10 s bound in process against raw pybullet stepping of the same model, in one run.

    python bench/cosim.py --json out/bench/cosim.json [--repeat 3]

Three figures, each the best of `--repeat` runs:
- raw: `stepSimulation` of the model for the same simulated time with zero torques (the robot collapses
  onto the ground, so its contacts differ from a bound's);
- physics share: the time spent inside `stepSimulation` during the bound itself (same contacts);
- in process: the whole bound (estimator, impedance controller, leg controller, logging, stepping).
The LCM lockstep leg is reported as unavailable until the spine node (issue 3) is on main.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import pybullet as pb

from sparc_quad.sim.bound_run import BoundConfig, run_bound
from sparc_quad.sim.quadruped_world import QuadrupedWorld, WorldConfig


def raw_stepping(duration_s: float) -> float:
    world = QuadrupedWorld(WorldConfig())
    n = round(duration_s / world.cfg.dt_s)
    zeros = [0.0] * len(world.movable)
    t0 = time.perf_counter()
    for _ in range(n):
        pb.setJointMotorControlArray(world.robot, world.movable, pb.TORQUE_CONTROL, forces=zeros,
                                     physicsClientId=world.client)
        pb.stepSimulation(physicsClientId=world.client)
    wall = time.perf_counter() - t0
    world.close()
    return wall


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--json", type=Path, required=True)
    ap.add_argument("--duration", type=float, default=10.0)
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    raws, bounds, physics = [], [], []
    fell = False
    for _ in range(args.repeat):
        raws.append(raw_stepping(args.duration))
        res = run_bound(BoundConfig(duration_s=args.duration))
        bounds.append(res.wall_s)
        physics.append(res.metrics["physics_wall_time_s"])
        fell |= res.metrics["fell"]
    raw, inproc, phys = min(raws), min(bounds), min(physics)
    out = {
        "sim_s": args.duration,
        "repeat": args.repeat,
        "raw_zero_torque_wall_s": raw,
        "bound_physics_only_wall_s": phys,
        "in_process_bound_wall_s": inproc,
        "in_process_vs_raw_zero_torque": raw / inproc,
        "in_process_vs_physics_only": phys / inproc,
        "in_process_real_time_factor": args.duration / inproc,
        "lcm_lockstep_wall_s": None,
        "lcm_note": "not measured: the spine node (issue 3) is not on main yet",
        "bound_fell": fell,
        "all_runs_s": {"raw": raws, "in_process": bounds, "physics_only": physics},
    }
    args.json.parent.mkdir(parents=True, exist_ok=True)
    args.json.write_text(json.dumps(out, indent=2) + "\n")
    print(json.dumps(out, indent=2))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
