"""`sparc-quad bench-robot`: the stand-in robot, the pybullet bench spine on the robot side of LCM.

    sparc-quad bench-robot --lcm-url URL --clock lockstep --experiment static --kx 500 --out out/robot
"""

from __future__ import annotations

import argparse
import logging
import math

import numpy as np

from sparc_quad.cli.args import SIM_DURATION_MAX_S, add_spin_option, lcm_url, output_dir, sim_duration, wait_s
from sparc_quad.cli.errors import BadInput
from sparc_quad.cli.experiment import add_experiment_args, plant, script
from sparc_quad.cli.signals import stop_on_signals
from sparc_quad.jsonfmt import json_text
from spine_module.messages import channels

log = logging.getLogger("sparc_quad.cli.bench_robot")


def register(sub: argparse._SubParsersAction) -> None:
    r = sub.add_parser("bench-robot",
                       help="stand-in robot: the pybullet bench spine on the robot side of LCM",
                       description="Runs the pybullet bench spine and speaks the robot's side of the spine "
                                   "interface: publishes motor feedback, torso state, heartbeat and the "
                                   "script's spine commands; applies motor commands.")
    r.add_argument("--lcm-url", type=lcm_url, default=channels.DEFAULT_URL,
                   help="LCM URL (default: $LCM_DEFAULT_URL or %(default)s)")
    r.add_argument("--clock", choices=["realtime", "lockstep"], default="realtime",
                   help="realtime: step the world at 1 kHz of wall time; lockstep: one step per motor "
                        "command from the node (as fast as both can go)")
    add_spin_option(r)
    r.add_argument("--duration", type=sim_duration, default=None,
                   help=f"seconds of robot time, at most {SIM_DURATION_MAX_S:g} (default: the script's)")
    r.add_argument("--wait-node", type=wait_s, default=30.0,
                   help="wait this long (wall s) for the node's first heartbeat before stepping")
    r.add_argument("--out", type=output_dir, default=None,
                   help="write bench_robot.npz (robot log and the node's states) and summary.json here "
                        "(default: write nothing)")
    r.add_argument("--effect", action="append", default=[], metavar="NAME[:key=value,...]",
                   help="hide a named effect in the plant (repeatable; the syntax and registry of `gap synth "
                        "--effect`, e.g. coulomb_friction:joint=q3,tau_c_nm=0.02; torque_saturation needs "
                        "limit_nm): a whole session over LCM then carries it")
    add_experiment_args(r)
    r.set_defaults(func=run, extra="sim")


def plant_with_effects(args: argparse.Namespace):
    """The experiment's plant with the --effect entries on top, checked before any resource is taken."""
    from dataclasses import replace

    from sparc_quad.cli.gap import _spine_effects
    from sparc_quad.effects import kind
    from sparc_quad.effects.plant import PlantEffects
    from spine_module import params as P

    base = plant(args)
    if not args.effect:
        return base
    effects = _spine_effects(args.effect)

    # a synth-only key that needs the run's peak torque (saturation's limit_fraction) resolves to NaN
    for e in effects:
        kind(e.name).resolve_synth(e.params, P.ACTUATED_JOINTS.index(e.joint), lambda _j: math.nan)
        if any(isinstance(v, float) and not math.isfinite(v) for v in e.params.values()):
            raise BadInput(f"--effect {e.name} on the bench needs its value in N*m (e.g. limit_nm): the "
                           "run's peak torque is not known before it runs")
    pe = PlantEffects(list(P.ACTUATED_JOINTS), effects, 1.0 / base.friction.beta_s_rad)
    if pe.model_effects():
        names = sorted({e.name for e in pe.model_effects()})
        raise BadInput(f"--effect {', '.join(names)}: changes the rigid bodies, which the pybullet bench "
                       "does not take (put it in the URDF)")
    return replace(base, effects=pe)


def run(args: argparse.Namespace) -> int:
    from sparc_quad.cli.output import atomic_dir
    from sparc_quad.experiments.stats import stiffness_from_states
    from sparc_quad.robot_side.bench import BenchRobot
    from sparc_quad.robot_side.ports import LcmPort
    from sparc_quad.robot_side.states import states_arrays
    from sparc_quad.sim.bench_world import BenchWorld

    s = script(args)
    world_plant = plant_with_effects(args)
    try:
        port = LcmPort(args.lcm_url, spin_s=args.spin_us * 1e-6 if args.clock == "lockstep" else 0.0)
    except RuntimeError as exc:
        raise BadInput(f"cannot open LCM at {args.lcm_url!r} (a multicast route is needed, see docs): "
                       f"{exc}") from exc
    try:
        with BenchWorld(plant=world_plant, seed=args.seed) as world, stop_on_signals() as stop:
            robot = BenchRobot(world, port, s)
            # the world stays frozen until a node is up (unpowered, the spine would sag under gravity)
            if not robot.wait_for_node(args.wait_node):
                log.error("no heartbeat from a spine node within %g s", args.wait_node)
                return 1
            rate = None
            try:
                if args.clock == "lockstep":
                    robot.run_lockstep(stop=stop.is_set)
                else:
                    rate = robot.run_realtime(stop=stop.is_set)
            except OSError:  # LCM's select() cut by the signal that set `stop` (EINTR) is the stop
                if not stop.is_set():
                    raise
            states = port.drain_states(0.3)  # the node's last states still in flight
        summary = {"ticks": robot.k, "unanswered": robot.unanswered, "retransmits": robot.retransmits,
                   "node_states": len(states),
                   "latched": robot.latched, "achieved_rate_hz": rate, "rejected": port.rejected}
        if args.experiment == "static" and states:
            summary["k_hat_n_m"] = stiffness_from_states(states)
        print(json_text(summary))
        if args.out is not None:
            with atomic_dir(args.out) as tmp:
                arrays = {f"robot_{k}": v for k, v in robot.log.arrays().items()}
                if states:
                    arrays.update(states_arrays(states))
                np.savez(tmp / "bench_robot.npz", **arrays)
                (tmp / "summary.json").write_text(json_text(summary, indent=2))
    finally:
        port.close()
    return stop.exit_code()
