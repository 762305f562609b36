"""MuJoCo against pybullet on the same robot and gait, in one run: simulated seconds per CPU second of the
whole bound loop and of the engine step alone, and the share of the loop that is physics.

The trial is the stiffness study's (`sparc_quad.study.fixed_trial.bound_config`): gait A (`sine`, the
authors' variant) on the spined dog, L = 0.08 m, k_x 800 N/m, 10 s, seed 0, the study's spine schedule
and spine rate. Each engine
runs `--repeat` times, interleaved (a burst of load hits both alike); each figure is the best run's.

- loop: simulated s / CPU s (time.process_time) of `run_bound`, world construction and metrics included;
- engine step alone: simulated s / wall s inside mj_step or stepSimulation during the same bound
  (`world.physics_wall_s`, perf_counter: only the engine call, not the state read after it);
- outside the loop: the share of run_bound's wall time spent before and after the stepping loop (world set-up,
  metrics), and `loop_only_sim_s_per_cpu_s`, the loop alone (the call's CPU times the loop's wall share);
- physics share: that engine-step wall time / the loop's wall time (same clock, same run; as
  bench/cosim.py). The thread's CPU clock (time.thread_time) around each ~20 us step was tried and is not
  usable on this machine: under load its sum over a bound exceeded the whole process's CPU time.
- phases: one profiled run per engine (run_bound's per-phase perf_counter accumulators; `physics` there
  is world.step: torques in, engine step, state read). Profiling runs every step through the full path,
  so these shares are the full path's.
- held steps: MuJoCo runs the steps between the gait's control calls in chunks (`QuadWorld.step_chunk`,
  see sparc_quad/bound/held_loop.py); `held_share` is the share of steps that went through them. The same
  bound with every step through the full path (`run_bound(..., held_steps=False)`, identical series) is
  run alongside, interleaved, as `mujoco_full_path`, and `held_over_full_loop` is the ratio of the two
  loops' sim s per CPU s measured in this run. In a chunk the engine-step time is still the sum of the
  perf_counter intervals around each mj_step, so the physics share means the same on both paths.

Goal: the MuJoCo bound of the spined dog at >= 20 simulated s per CPU s with physics >= 0.5.

    python bench/engines.py --json out/bench/engines.json [--repeat 3] [--duration 10] [--host spined-dog]
        [--gait sine|authors-raibert]
"""

from __future__ import annotations

import argparse
import json
import sys
import time
import warnings
from pathlib import Path

from sparc_quad.bound.run import PROFILE_PHASES, run_bound
from sparc_quad.sim.engines import ENGINES, engine_error
from sparc_quad.study.trial import config_of as bound_config

GOAL_SIM_S_PER_CPU_S = 20.0
GOAL_PHYSICS_SHARE = 0.5


GAITS = ("sine", "authors-raibert")


def trial(engine: str, host: str, duration_s: float, gait: str = "sine") -> dict:
    """Gait A (the authors' sine bound, L 0.08 m, k_x 800 N/m) or gait C (their speed-commanded Raibert
    bound at 0.9 m/s, their later model: joint friction and damping), seed 0."""
    if gait == "authors-raibert":
        return {"gait": gait, "host": host, "engine": engine, "duration": duration_s, "speed": 0.9, "seed": 0}
    return {"gait": "sine", "variant": "authors", "host": host, "engine": engine, "duration": duration_s,
            "step_length": 0.08, "kx": 800.0, "seed": 0}


def one_run(engine: str, host: str, duration_s: float, profile: dict | None = None,
            held_steps: bool = True, gait: str = "sine") -> dict:
    cfg = bound_config(trial(engine, host, duration_s, gait))
    c0, w0 = time.process_time(), time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # a short or fallen run's metric warnings
        res = run_bound(cfg, profile=profile, held_steps=held_steps)
    cpu, call_wall = time.process_time() - c0, time.perf_counter() - w0
    m = res.metrics
    sim = m["simulated_s"]
    return {
        "simulated_s": sim,
        "fell": m["fell"],
        "fall_time_s": m["fall_time_s"],
        "speed_m_s": m.get("speed_m_s"),
        "cpu_s": cpu,
        "loop_wall_s": m["wall_time_s"],
        "engine_step_wall_s": m["physics_wall_time_s"],
        "loop_sim_s_per_cpu_s": sim / cpu,
        "engine_sim_s_per_s": sim / m["physics_wall_time_s"],
        "physics_share": m["physics_wall_time_s"] / m["wall_time_s"],
        # the run's cost outside the stepping loop (world set-up, metrics), as a share of the call's wall
        # time, and the loop alone: the call's CPU scaled by the loop's share of its wall time
        "outside_loop_share": 1.0 - m["wall_time_s"] / call_wall,
        "loop_only_sim_s_per_cpu_s": sim / (cpu * m["wall_time_s"] / call_wall),
        "held_share": m["held_steps"] / max(1, len(res.series)),
        "spine_backend": m.get("spine_backend"),
        "gait_backend": m.get("gait_backend"),
    }


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--json", type=Path, required=True)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--duration", type=float, default=10.0, help="simulated s per run")
    ap.add_argument("--host", default="spined-dog")
    ap.add_argument("--gait", choices=GAITS, default="sine",
                    help="sine: gait A (default); authors-raibert: gait C at 0.9 m/s")
    args = ap.parse_args()
    if args.repeat < 1 or args.duration <= 0:
        print("engines: need --repeat >= 1 and --duration > 0", file=sys.stderr)
        return 2
    engines = [e for e in ENGINES if engine_error(e) is None]
    skipped = {e: engine_error(e) for e in ENGINES if e not in engines}
    runs: dict[str, list[dict]] = {e: [] for e in engines}
    full: list[dict] = []  # MuJoCo with every step through the full path
    for _ in range(args.repeat):
        for e in engines:
            runs[e].append(one_run(e, args.host, args.duration, gait=args.gait))
            if e == "mujoco":
                full.append(one_run(e, args.host, args.duration, held_steps=False, gait=args.gait))
    result: dict = {"host": args.host, "trial": trial("<engine>", args.host, args.duration, args.gait),
                    "repeat": args.repeat, "skipped": skipped}
    for e in engines:
        best = max(runs[e], key=lambda r: r["loop_sim_s_per_cpu_s"])
        prof: dict[str, float] = {}
        one_run(e, args.host, args.duration, profile=prof, gait=args.gait)
        total = sum(prof.values())
        result[e] = {**best, "phase_share": {k: prof[k] / total for k in PROFILE_PHASES},
                     "phase_us_per_step": {k: 1e6 * prof[k] / (args.duration * 1000) for k in PROFILE_PHASES},
                     "all_runs": runs[e]}
    if full:
        result["mujoco_full_path"] = {**max(full, key=lambda r: r["loop_sim_s_per_cpu_s"]), "all_runs": full}
        result["held_over_full_loop"] = (result["mujoco"]["loop_sim_s_per_cpu_s"]
                                         / result["mujoco_full_path"]["loop_sim_s_per_cpu_s"])
    if "mujoco" in result and "pybullet" in result:
        result["mujoco_over_pybullet_loop"] = (result["mujoco"]["loop_sim_s_per_cpu_s"]
                                               / result["pybullet"]["loop_sim_s_per_cpu_s"])
    if "mujoco" in result:
        mj = result["mujoco"]
        result["goal"] = {"sim_s_per_cpu_s": GOAL_SIM_S_PER_CPU_S, "physics_share": GOAL_PHYSICS_SHARE,
                          "met": bool(mj["loop_sim_s_per_cpu_s"] >= GOAL_SIM_S_PER_CPU_S
                                      and mj["physics_share"] >= GOAL_PHYSICS_SHARE)}
    load = Path("/proc/loadavg")
    result["loadavg"] = load.read_text().split()[:3] if load.exists() else None
    args.json.parent.mkdir(parents=True, exist_ok=True)
    args.json.write_text(json.dumps(result, indent=2) + "\n")
    for e in engines:
        r = result[e]
        phases = ", ".join(f"{k} {v:.2f}" for k, v in r["phase_share"].items())
        print(f"{e:9s} loop {r['loop_sim_s_per_cpu_s']:6.2f} sim s/CPU s, engine step alone "
              f"{r['engine_sim_s_per_s']:6.1f} sim s/s, physics share {r['physics_share']:.2f}, loop alone "
              f"{r['loop_only_sim_s_per_cpu_s']:.1f} sim s/CPU s ({r['outside_loop_share']:.2f} of the run "
              f"outside it); "
              f"held {r['held_share']:.2f} of the steps; "
              f"fell {r['fell']} ({r['fall_time_s']}), {r['speed_m_s']} m/s; "
              f"full path's shares (wall): {phases}")
    if full:
        f = result["mujoco_full_path"]
        print(f"mujoco, every step in full: loop {f['loop_sim_s_per_cpu_s']:6.2f} sim s/CPU s, physics share "
              f"{f['physics_share']:.2f}; held / full loop {result['held_over_full_loop']:.3f} (this run)")
    for e, why in skipped.items():
        print(f"{e:9s} skipped: {why}")
    if "goal" in result:
        print(f"goal (MuJoCo >= {GOAL_SIM_S_PER_CPU_S} sim s/CPU s, physics >= {GOAL_PHYSICS_SHARE}): "
              f"{'met' if result['goal']['met'] else 'NOT met'}; load {' '.join(result['loadavg'] or [])}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
