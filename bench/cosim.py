"""Loop cost of a 10 s bound against the physics time inside the same bound, in one run.

Headline: `in_process_vs_physics_only` = time in `stepSimulation` during the bound / whole bound wall time
(goal >= 0.5: the loop costs no more than the physics it drives), and `phase_share` = the per-phase split of
one bound step from run_bound's profiling hook (perf_counter accumulators, wall time) in a separate profiled
run. The zero-torque "raw" stepping is context only (the robot collapses, so its contacts differ).

    python bench/cosim.py --json out/bench/cosim.json [--repeat 3] [--backend numba|python|auto]

The bound runs the compiled per-step code (`--backend numba`, what `sparc-quad bound` picks for runs of 8 s
or longer; loading it is a per-process cost that bench/run_cost.py measures), which runs the control half of
each step in one compiled call (`bound.compiled_loop`; `loop` says which loop ran); one run with the other
backend is reported beside it as `context_<backend>_backend_vs_physics_only`, and one with the same compiled
controllers called from the Python loop (`run_bound(..., compiled_loop=False)`, the reference of the
compiled loop, the same series bit for bit) as `context_python_loop_vs_physics_only`.

Three figures, each the best of `--repeat` runs:
- raw: `stepSimulation` of the model for the same simulated time with zero torques (the robot collapses
  onto the ground, so its contacts differ from a bound's);
- physics share: the time spent inside `stepSimulation` during the bound itself (same contacts);
- in process: the whole bound (estimator, impedance controller, leg controller, logging, stepping).
- node in process: the same bound with the spine node ticked in this process (in-process bus);
- LCM lockstep: `sparc-quad bound --lcm` and `sparc-quad spine-node --motors lcm --clock lockstep` as two
  processes on UDP multicast inside a private network namespace (skipped where one cannot be made), pinned
  to two CPUs; its figure is the bound's own wall time as the robot process measured it. The goal
  ratio against the in-process bound is `bench/lcm_loop.py`'s `lcm_lockstep_over_in_process`.
"""

from __future__ import annotations

import argparse
import json
import os
import shlex
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pybullet as pb

from sparc_quad.bound.run import PROFILE_PHASES, BoundConfig, run_bound
from sparc_quad.robot_side.quad import NodeSpine
from sparc_quad.sim.quadruped_world import QuadrupedWorld, WorldConfig

ROOT = Path(__file__).resolve().parents[1]
NETNS_SETUP = "ip link set lo up multicast on && ip route add 224.0.0.0/4 dev lo\n"


def lcm_lockstep(duration_s: float) -> tuple[float | None, str]:
    """Wall time of the bound over LCM lockstep (robot and node in separate processes), or None + why."""
    if shutil.which("unshare") is None or shutil.which("ip") is None:
        return None, "no unshare/ip here"
    py = shlex.quote(sys.executable)
    cpus = sorted(os.sched_getaffinity(0))  # node and robot on two CPUs, as bench/lcm_loop.py (see there)
    pin_node, pin_robot = ((f"taskset -c {cpus[-1]} ", f"taskset -c {cpus[0]} ")
                           if len(cpus) > 1 and shutil.which("taskset") else ("", ""))
    with tempfile.TemporaryDirectory() as tmp:
        out = shlex.quote(tmp)
        script = (f"set -e\n{NETNS_SETUP}export PYTHONPATH={shlex.quote(str(ROOT))}\n"
                  f"{pin_node}{py} -m sparc_quad spine-node --motors lcm --clock lockstep --idle-timeout 3 "
                  f"> {out}/node.out 2> {out}/node.err &\nNODE=$!\n"
                  f"{pin_robot}{py} -m sparc_quad bound --lcm --no-plots --duration {duration_s} --out {out} "
                  f"> {out}/robot.out 2> {out}/robot.err\nwait $NODE\n")
        for prefix in (("unshare", "-rn"), ("unshare", "-n")):
            r = subprocess.run([*prefix, "sh", "-c", script], capture_output=True, text=True, timeout=900)
            metrics = Path(tmp) / "metrics.json"
            if r.returncode == 0 and metrics.exists():
                return float(json.loads(metrics.read_text())["wall_time_s"]), "ok"
        return None, f"netns run failed: {r.stderr[-500:]}"


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
    ap.add_argument("--no-lcm", action="store_true", help="skip the LCM lockstep leg")
    ap.add_argument("--backend", choices=["auto", "numba", "python"], default="numba",
                    help="the bound's per-step code (BoundConfig.backend; default numba, what `bound` runs "
                         "for 8 s or longer); one run with the other of numba/python is reported as context")
    args = ap.parse_args()
    raws, bounds, physics, nodes, lcms, cpus = [], [], [], [], [], []
    fell = False
    note = "skipped (--no-lcm)"
    for _ in range(args.repeat):
        raws.append(raw_stepping(args.duration))
        cfg = BoundConfig(duration_s=args.duration, backend=args.backend)
        c0 = time.process_time()
        res = run_bound(cfg)
        loop = res.metrics["loop"]
        cpus.append(time.process_time() - c0)
        bounds.append(res.wall_s)
        physics.append(res.metrics["physics_wall_time_s"])
        fell |= res.metrics["fell"]
        res = run_bound(cfg, spine=NodeSpine.inprocess(cfg.spine))
        nodes.append(res.wall_s)
        fell |= res.metrics["fell"]
        if not args.no_lcm:
            wall, note = lcm_lockstep(args.duration)
            if wall is not None:
                lcms.append(wall)
    profile: dict[str, float] = {}
    prof_res = run_bound(BoundConfig(duration_s=args.duration, backend=args.backend), profile=profile)
    other = "python" if prof_res.metrics["gait_backend"] == "numba" else "numba"
    ctx = run_bound(BoundConfig(duration_s=args.duration, backend=other))
    py_loop = run_bound(BoundConfig(duration_s=args.duration, backend=args.backend), compiled_loop=False)
    total = sum(profile.values())
    raw, inproc, phys = min(raws), min(bounds), min(physics)
    node = min(nodes)
    lcm_wall = min(lcms) if lcms else None
    out = {
        "sim_s": args.duration,
        "repeat": args.repeat,
        "in_process_vs_physics_only": phys / inproc,
        "backend": {"asked": args.backend, "spine": prof_res.metrics["spine_backend"],
                    "gait": prof_res.metrics["gait_backend"]},
        "loop": loop,
        f"context_{other}_backend_vs_physics_only": ctx.metrics["physics_wall_time_s"] / ctx.wall_s,
        "context_python_loop_vs_physics_only": py_loop.metrics["physics_wall_time_s"] / py_loop.wall_s,
        "phase_wall_s": {k: profile[k] for k in PROFILE_PHASES},
        "phase_share": {k: profile[k] / total for k in PROFILE_PHASES},
        "profiled_bound_wall_s": prof_res.wall_s,
        "in_process_bound_cpu_s": min(cpus),
        "raw_zero_torque_wall_s": raw,
        "bound_physics_only_wall_s": phys,
        "in_process_bound_wall_s": inproc,
        "context_in_process_vs_raw_zero_torque": raw / inproc,
        "in_process_real_time_factor": args.duration / inproc,
        "node_in_process_wall_s": node,
        "context_node_in_process_vs_raw_zero_torque": raw / node,
        "lcm_lockstep_wall_s": lcm_wall,
        "context_lcm_lockstep_vs_raw_zero_torque": raw / lcm_wall if lcm_wall else None,
        "lcm_lockstep_real_time_factor": args.duration / lcm_wall if lcm_wall else None,
        "lcm_note": note,
        "bound_fell": fell,
        "all_runs_s": {"raw": raws, "in_process": bounds, "physics_only": physics, "node_in_process": nodes,
                       "lcm_lockstep": lcms},
    }
    args.json.parent.mkdir(parents=True, exist_ok=True)
    args.json.write_text(json.dumps(out, indent=2) + "\n")
    print(json.dumps(out, indent=2))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
