"""Wall time of a 10 s bound in process vs raw pybullet stepping of the same model with zero torques.

    python bench/cosim.py --json out/bench/cosim.json

Prints ratios measured in the same run. The LCM lockstep leg is reported as unavailable until the spine
node (issue 3) is on main.
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
    args = ap.parse_args()
    raw = raw_stepping(args.duration)
    res = run_bound(BoundConfig(duration_s=args.duration))
    inproc = res.wall_s
    out = {
        "sim_s": args.duration,
        "raw_zero_torque_wall_s": raw,
        "in_process_bound_wall_s": inproc,
        "in_process_vs_raw_speed": raw / inproc,
        "in_process_real_time_factor": args.duration / inproc,
        "raw_real_time_factor": args.duration / raw,
        "lcm_lockstep_wall_s": None,
        "lcm_note": "not measured: the spine node (issue 3) is not on main yet",
        "bound_fell": res.metrics["fell"],
        "note": "raw stepping with zero torques lets the robot collapse onto the ground (more contacts)",
    }
    args.json.parent.mkdir(parents=True, exist_ok=True)
    args.json.write_text(json.dumps(out, indent=2) + "\n")
    print(json.dumps(out, indent=2))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
