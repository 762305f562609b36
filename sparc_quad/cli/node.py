"""`sparc-quad spine-node` (the 1 kHz spine node) and `sparc-quad bench-robot` (the stand-in robot).

    sparc-quad bench-robot --lcm-url URL --clock lockstep --experiment static --kx 500 --out out/robot
    sparc-quad spine-node --motors lcm --lcm-url URL --clock lockstep

Both speak the channels documented in README ("Spine node and LCM interface").
"""

from __future__ import annotations

import argparse
import contextlib
import json
import logging
import signal
import threading
import time
from pathlib import Path

import numpy as np

from sparc_quad.cli.args import (
    add_can_options,
    add_gain_options,
    can_options,
    damping,
    finite_float,
    in_range,
    nonnegative_float,
    nonnegative_int,
    positive_float,
    positive_int,
    stiffness,
)
from spine_module import params as P
from spine_module.buses import registry
from spine_module.buses.base import MotorBusError
from spine_module.messages import Mode, channels
from spine_module.safety import SafetyConfig

log = logging.getLogger("sparc_quad.cli.node")


def _experiment_args(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group("bench experiment (the robot side's script)")
    g.add_argument("--experiment", choices=["hold", "static", "none"], default="hold",
                   help="hold: impedance at x_d with the default gains; static: push-pull along x "
                        "(paper Section IV-A); none: send no spine command (default: %(default)s)")
    add_gain_options(g, ("kx",), prefix="static: commanded ")
    g.add_argument("--amplitude", type=positive_float, default=0.025,
                   help="static: displacement the push aims for, m (default: %(default)s)")
    g.add_argument("--period", type=positive_float, default=8.0,
                   help="static: push-pull period, s (default: %(default)s)")
    g.add_argument("--cycles", type=positive_float, default=1.0, help="static: cycles (default: %(default)s)")
    g.add_argument("--seed", type=nonnegative_int, default=0, help="plant noise seed (default: %(default)s)")
    g.add_argument("--ideal-plant", action="store_true", help="plant = model: no quantisation, no noise")


def _script(args: argparse.Namespace):
    from sparc_quad.experiments.scripts import hold_script, static_push_script
    from sparc_quad.robot_side.scripts import BenchScript

    if args.experiment == "static":
        s = static_push_script(args.kx, args.amplitude, args.period, args.cycles)
    elif args.experiment == "hold":
        s = hold_script()
    else:
        s = BenchScript()
    if args.duration is not None:
        s.duration_s = args.duration
    return s


def _plant(args: argparse.Namespace):
    from sparc_quad.sim.plant import PlantConfig

    return PlantConfig().ideal() if args.ideal_plant else PlantConfig()


@contextlib.contextmanager
def _stop_on_signals():
    """An Event set by SIGINT/SIGTERM for the duration of the block (previous handlers restored)."""
    ev = threading.Event()
    old = {sig: signal.signal(sig, lambda *_: ev.set()) for sig in (signal.SIGINT, signal.SIGTERM)}
    try:
        yield ev
    finally:
        for sig, handler in old.items():
            signal.signal(sig, handler)


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("spine-node", help="run the spine node: motors via a bus backend, LCM interface",
                       description="The 1 kHz spine node: reads motor feedback from --motors, torso state "
                                   "and commands from LCM, runs the controller and the safety logic, sends "
                                   "torques, publishes SPARC_SPINE_STATE and a heartbeat.")
    p.add_argument("--motors", default="lcm", choices=sorted(registry.BACKENDS),
                   help="motor bus backend (default: %(default)s; inprocess runs the bench robot in this "
                        "process, in lockstep)")
    p.add_argument("--lcm-url", default=channels.DEFAULT_URL,
                   help="LCM URL (default: $LCM_DEFAULT_URL or %(default)s)")
    p.add_argument("--rate", type=positive_float, default=P.CONTROL_RATE_HZ,
                   help="control rate, Hz (default: %(default)s)")
    p.add_argument("--clock", choices=["realtime", "lockstep"], default="realtime",
                   help="realtime: fixed-rate loop; lockstep: one step per motor feedback tick")
    p.add_argument("--duration", type=positive_float, default=None,
                   help="stop after this many seconds of node time")
    p.add_argument("--idle-timeout", type=positive_float, default=5.0,
                   help="lockstep: stop after this much wall time without motor feedback once the robot "
                        "has been heard (before: 120 s, for a robot slow to start) (default: %(default)s)")
    p.add_argument("--no-heartbeat", action="store_true",
                   help="do not require the robot side's heartbeat (bench use without a PMU-like peer)")
    p.add_argument("--soft-start", type=nonnegative_float, default=P.SAFETY.soft_start_s,
                   help="gain ramp-in time on entering impedance/PD mode, s (default: %(default)s)")
    p.add_argument("--state-every", type=positive_int, default=1, help="publish spine state every N ticks")
    p.add_argument("--summary", type=Path, default=None, help="write a JSON summary of the run here")
    rt = p.add_argument_group("real time (torso computer; see README 'Running on a PREEMPT_RT kernel')")
    rt.add_argument("--cpu", type=nonnegative_int, default=None,
                    help="pin the node to this CPU (isolate it with isolcpus=N on the kernel command line)")
    rt.add_argument("--rt-priority", type=in_range(1, 99, kind=int), default=None,
                    help="run under SCHED_FIFO at this priority, 1..99 (needs root, CAP_SYS_NICE or rtprio)")
    rt.add_argument("--lock-memory", action="store_true",
                    help="lock the process's memory (mlockall) so no page fault stalls a tick; best effort")
    add_can_options(p)
    _experiment_args(p)
    p.set_defaults(func=run_node)

    r = sub.add_parser("bench-robot",
                       help="stand-in robot: the pybullet bench spine on the robot side of LCM",
                       description="Runs the pybullet bench spine and speaks the robot's side of the spine "
                                   "interface: publishes motor feedback, torso state, heartbeat and the "
                                   "script's spine commands; applies motor commands.")
    r.add_argument("--lcm-url", default=channels.DEFAULT_URL,
                   help="LCM URL (default: $LCM_DEFAULT_URL or %(default)s)")
    r.add_argument("--clock", choices=["realtime", "lockstep"], default="realtime")
    r.add_argument("--duration", type=positive_float, default=None,
                   help="seconds of robot time (default: the script's)")
    r.add_argument("--wait-node", type=positive_float, default=30.0,
                   help="wait this long (wall s) for the node's first heartbeat before stepping "
                        "(default: %(default)s)")
    r.add_argument("--out", type=Path, default=None,
                   help="write bench_robot.npz (robot log and the node's states) and summary.json here")
    _experiment_args(r)
    r.set_defaults(func=run_bench_robot, extra="sim")

    c = sub.add_parser("spine-cmd", help="send spine commands (mode, target, gains, E-stop, reset) over LCM",
                       description="Publish sparc.spine_command_t on SPARC_SPINE_COMMAND, as a torso "
                                   "computer does. The node holds the last target with default gains when "
                                   "commands stop for 200 ms, so send at a rate for as long as the command "
                                   "should hold.")
    c.add_argument("--lcm-url", default=channels.DEFAULT_URL, help="LCM URL (default: %(default)s)")
    c.add_argument("--mode", choices=[m.name.lower().replace("_", "-") for m in Mode], default="impedance")
    c.add_argument("--x-d", type=finite_float, nargs=3, default=list(P.X_EQUILIBRIUM),
                   metavar=("X", "Z", "THETA"),
                   help="target pose: x m, z m, theta rad (default: %(default)s)")
    add_gain_options(c)
    c.add_argument("--tau-ff", type=finite_float, nargs=3, default=[0.0, 0.0, 0.0],
                   metavar=("T2", "T3", "T4"),
                   help="joint feed-forward torques q2..q4, N*m")
    c.add_argument("--no-friction", action="store_true",
                   help="impedance without eq. (4) friction compensation")
    c.add_argument("--reset", action="store_true", help="ask the node to clear latched faults")
    c.add_argument("--rate", type=positive_float, default=50.0,
                   help="messages per second (default: %(default)s)")
    c.add_argument("--duration", type=nonnegative_float, default=0.0,
                   help="seconds to keep sending (default: 0 = one message)")
    c.set_defaults(func=run_spine_cmd)

    e = sub.add_parser("spine-echo", help="print decoded SPARC_* LCM messages, one JSON line each",
                       description="Subscribe to the spine interface's channels and print every message, "
                                   "decoded and validated (rejected ones are printed with the reason).")
    e.add_argument("--lcm-url", default=channels.DEFAULT_URL, help="LCM URL (default: %(default)s)")
    e.add_argument("--channels", default="SPARC_.*", help="channel regex (default: %(default)s)")
    e.add_argument("--count", type=nonnegative_int, default=0,
                   help="stop after this many messages (0: never)")
    e.add_argument("--timeout", type=nonnegative_float, default=0.0,
                   help="stop after this many seconds (0: never)")
    e.set_defaults(func=run_spine_echo)


def _mode(name: str) -> Mode:
    return Mode[name.upper().replace("-", "_")]


def run_spine_cmd(args: argparse.Namespace) -> int:
    import lcm

    from spine_module.messages import MessageError, SpineCommand, codec

    cmd = SpineCommand(mode=_mode(args.mode), x_d=np.array(args.x_d), k=np.array(stiffness(args)),
                       d=np.array(damping(args)),
                       tau_ff=np.array(args.tau_ff), friction_compensation=not args.no_friction,
                       reset=args.reset)
    try:  # validate before sending: the node would reject it anyway, naming the same field
        codec.decode_command(codec.encode_command(cmd))
    except MessageError as exc:
        log.error("not sent: %s", exc)
        return 2
    try:
        lc = lcm.LCM(args.lcm_url)
    except RuntimeError as exc:
        log.error("cannot open LCM at %r: %s", args.lcm_url, exc)
        return 2
    n = max(1, round(args.duration * args.rate))
    t0 = time.monotonic()
    for i in range(n):
        cmd.seq, cmd.stamp_s = i, time.time()
        lc.publish(channels.SPINE_COMMAND, codec.encode_command(cmd))
        if i + 1 < n:
            time.sleep(max(0.0, t0 + (i + 1) / args.rate - time.monotonic()))
    print(json.dumps({"sent": n, "mode": cmd.mode.name}))
    return 0


def _jsonable(msg) -> dict:
    from dataclasses import asdict, is_dataclass

    if isinstance(msg, tuple):  # (motor command, feedback seq it answers)
        out = _jsonable(msg[0])
        out["feedback_seq"] = msg[1]
        return out
    d = asdict(msg) if is_dataclass(msg) else dict(vars(msg))
    return {k: (v.tolist() if isinstance(v, np.ndarray) else (v.name if hasattr(v, "name") else v))
            for k, v in d.items()}


def echo_line(channel: str, data: bytes) -> dict:
    """One received message as a JSON-able dict: its decoded fields, or why it was rejected."""
    from spine_module.messages import MessageError, decode

    try:
        return {"channel": channel, **_jsonable(decode(channel, data))}
    except MessageError as exc:
        return {"channel": channel, "rejected": str(exc)}
    except Exception as exc:  # a decoder bug must not end the echo: report the packet and go on
        return {"channel": channel, "rejected": f"{type(exc).__name__} while decoding: {exc}"}


def run_spine_echo(args: argparse.Namespace) -> int:
    import lcm

    try:
        lc = lcm.LCM(args.lcm_url)
    except RuntimeError as exc:
        log.error("cannot open LCM at %r: %s", args.lcm_url, exc)
        return 2
    seen = [0]

    def on_message(channel: str, data: bytes) -> None:
        seen[0] += 1
        print(json.dumps(echo_line(channel, data), default=str), flush=True)

    lc.subscribe(args.channels, on_message)
    deadline = time.monotonic() + args.timeout if args.timeout > 0 else None
    with _stop_on_signals() as stop:
        while not stop.is_set() and (args.count <= 0 or seen[0] < args.count):
            if deadline is not None and time.monotonic() > deadline:
                break
            lc.handle_timeout(100)
    return 0


def _node_config(args: argparse.Namespace):
    from spine_module.node import NodeConfig

    return NodeConfig(rate_hz=args.rate, state_every=args.state_every,
                      safety=SafetyConfig(soft_start_s=args.soft_start,
                                          heartbeat_required=not args.no_heartbeat))


def _bus_options(args: argparse.Namespace) -> dict[str, object]:
    """The chosen backend's options as keyword arguments (see spine_module.buses.registry)."""
    if args.motors == "can":
        return can_options(args)
    if args.motors == "lcm":
        return {"url": args.lcm_url}
    return {}


def run_node(args: argparse.Namespace) -> int:
    import lcm

    from spine_module.node import Controllers, LcmNodeIO, SpineNode, realtime, run_lockstep, run_realtime

    try:
        rt_done = realtime.apply(realtime.RtOptions(cpu=args.cpu, rt_priority=args.rt_priority,
                                                    lock_memory=args.lock_memory))
        for line in rt_done:
            log.log(logging.WARNING if " not " in line else logging.INFO, "spine-node: %s", line)
    except realtime.RtSetupError as exc:
        log.error("%s", exc)
        return 2
    if args.motors == "inprocess":
        return _run_node_inprocess(args)
    try:
        lc = lcm.LCM(args.lcm_url)
    except RuntimeError as exc:
        log.error("cannot open LCM at %r (a multicast route is needed, see README): %s", args.lcm_url, exc)
        return 2
    try:
        bus = registry.make_bus(args.motors, lc=lc, **_bus_options(args))
    except ValueError as exc:
        log.error("%s", exc)
        return 2
    io = LcmNodeIO(lc)
    node = SpineNode(Controllers.default(), bus, io, _node_config(args))
    # before start(): a full collection holds the interpreter for tens of ms, during which nothing could
    # feed the motors that start() enabled (their CAN timeout is 50 ms)
    rt_done.append(realtime.freeze_startup_objects())
    try:
        bus.start()
    except MotorBusError as exc:  # e.g. a motor that did not answer: say which, stop the others, exit
        log.error("motor bus start-up failed: %s", exc)
        bus.shutdown()
        io.close()
        return 1
    log.info("spine-node: motors=%s clock=%s rate=%.0f Hz", args.motors, args.clock, args.rate)
    try:
        with _stop_on_signals() as stop:
            if args.clock == "lockstep":
                res = run_lockstep(node, args.duration, stop, idle_timeout_s=args.idle_timeout)
            else:
                res = run_realtime(node, args.duration, stop)
    finally:
        bus.shutdown()
        io.close()
    summary = {"ticks": res.ticks, "elapsed_wall_s": res.elapsed_wall_s,
               "achieved_rate_hz": res.achieved_rate_hz,
               "jitter_max_s": res.jitter_max_s, "overruns": res.overruns,
               "period": node.stats.histogram.summary(), "realtime": rt_done, "rejected": node.rejected_count,
               "rejected_by_channel": io.inbox.rejected,
               "last_faults": node.state.faults.name or "NONE", "last_rejected": node.rejected,
               "repeated_ticks": node.repeated_ticks,
               "bus_faults": list(getattr(bus, "latched_faults", [])),  # latched in the motor backend
               # messages superseded by a newer one before the node looked (a flood shows here)
               "dropped": {**io.inbox.dropped, **({"SPARC_MOTOR_FEEDBACK": bus.dropped}
                                                  if hasattr(bus, "dropped") else {})}}
    print(json.dumps(summary))
    if args.summary is not None:
        args.summary.parent.mkdir(parents=True, exist_ok=True)
        args.summary.write_text(json.dumps(summary, indent=2))
    return 0


def _run_node_inprocess(args: argparse.Namespace) -> int:
    from sparc_quad.experiments.stats import stiffness_from_states
    from sparc_quad.robot_side.bench import run_inprocess

    if args.clock != "lockstep":
        log.info("--motors inprocess always runs in lockstep (robot and node in one thread)")
    script = _script(args)
    robot, states = run_inprocess(script, _node_config(args), plant=_plant(args), seed=args.seed)
    out = {"ticks": robot.k, "final_x": [float(v) for v in states[-1].x] if states else None}
    if args.experiment == "static" and states:
        out["k_hat_n_m"] = stiffness_from_states(states)
    print(json.dumps(out))
    return 0


def run_bench_robot(args: argparse.Namespace) -> int:
    from sparc_quad.experiments.stats import stiffness_from_states
    from sparc_quad.robot_side.bench import BenchRobot
    from sparc_quad.robot_side.ports import LcmPort
    from sparc_quad.robot_side.states import states_arrays
    from sparc_quad.sim.bench_world import BenchWorld

    script = _script(args)
    try:
        port = LcmPort(args.lcm_url)
    except RuntimeError as exc:
        log.error("cannot open LCM at %r (a multicast route is needed, see README): %s", args.lcm_url, exc)
        return 2
    with BenchWorld(plant=_plant(args), seed=args.seed) as world, _stop_on_signals() as stop:
        robot = BenchRobot(world, port, script)
        # the world stays frozen until a node is up (unpowered, the spine would sag under gravity)
        if not robot.wait_for_node(args.wait_node):
            log.error("no heartbeat from a spine node within %.1f s", args.wait_node)
            return 1
        if args.clock == "lockstep":
            robot.run_lockstep(stop=stop.is_set)
            rate = None
        else:
            rate = robot.run_realtime(stop=stop.is_set)
        states = port.drain_states(0.3)  # the node's last states still in flight
    summary = {"ticks": robot.k, "unanswered": robot.unanswered, "retransmits": robot.retransmits,
               "node_states": len(states),
               "latched": robot.latched, "achieved_rate_hz": rate, "rejected": port.rejected}
    if args.experiment == "static" and states:
        summary["k_hat_n_m"] = stiffness_from_states(states)
    print(json.dumps(summary))
    if args.out is not None:
        args.out.mkdir(parents=True, exist_ok=True)
        arrays = {f"robot_{k}": v for k, v in robot.log.arrays().items()}
        if states:
            arrays.update(states_arrays(states))
        np.savez(args.out / "bench_robot.npz", **arrays)
        (args.out / "summary.json").write_text(json.dumps(summary, indent=2))
    port.close()
    return 0
