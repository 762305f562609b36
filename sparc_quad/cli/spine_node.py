"""`sparc-quad spine-node`: the 1 kHz spine node (motors via a bus backend, LCM interface).

    sparc-quad spine-node --motors lcm --lcm-url URL --clock lockstep
    sparc-quad spine-node --motors can --can-channel can0 --no-heartbeat --duration 5

It speaks the channels documented in docs (spine node and LCM interface).
"""

from __future__ import annotations

import argparse
import contextlib
import logging
import signal
import sys
import threading
from collections.abc import Iterator

from sparc_quad.cli.args import (
    NODE_RATE_MIN_HZ,
    SIM_DURATION_MAX_S,
    add_can_options,
    add_spin_option,
    add_wake_latency_option,
    can_options,
    in_range,
    lcm_url,
    node_rate,
    nonnegative_int,
    output_file,
    wait_s,
    wall_duration,
)
from sparc_quad.cli.errors import BadInput
from sparc_quad.cli.experiment import add_experiment_args, plant, script
from sparc_quad.cli.signals import Stop
from sparc_quad.jsonfmt import json_text
from spine_module import params as P
from spine_module.buses import registry
from spine_module.buses.base import MotorBusError, MotorSetupError
from spine_module.messages import channels
from spine_module.node.realtime import WAKE_LATENCY_DEFAULT_US
from spine_module.safety import SafetyConfig

log = logging.getLogger("sparc_quad.cli.spine_node")

# exit codes besides the CLI's (0 done or SIGTERM, 1 failed, 2 bad input, 130 Ctrl-C; docs/cli.md)
EXIT_LATCHED = 3  # the run ended with a fault latched (node or motor bus), whatever stopped it
# before it starts, the node listens this long for another node's heartbeat (every 10 ms in real time, every
# 50 ms from a lockstep node waiting for its robot)
NODE_LISTEN_S = 0.12
SOFT_START_MAX_S = 10.0  # a longer ramp leaves the spine soft for most of a run: a typo, not a setting


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("spine-node", help="run the spine node: motors via a bus backend, LCM interface",
                       description="The 1 kHz spine node: runs the controller and the safety logic between "
                                   "the motors and the torso computer. --motors can or lcm: motor feedback "
                                   "from that backend, torso state, commands and the robot's heartbeat from "
                                   "LCM (--lcm-url); publishes SPARC_SPINE_STATE and its heartbeat there. "
                                   "--motors inprocess: the bench robot and its scripted commands run in "
                                   "this process, nothing is read from or published to LCM. Exit codes: 0 "
                                   "done or SIGTERM, 1 a motor did not answer, 2 bad input, 3 the run ended "
                                   "with a latched fault, 130 Ctrl-C.")
    p.add_argument("--motors", default="lcm", choices=sorted(registry.BACKENDS),
                   help="motor bus backend (inprocess runs the bench robot in this process, in lockstep)")
    p.add_argument("--lcm-url", type=lcm_url, default=channels.DEFAULT_URL,
                   help="LCM URL (default: $LCM_DEFAULT_URL or %(default)s; unused with --motors inprocess)")
    p.add_argument("--rate", type=node_rate, default=P.CONTROL_RATE_HZ,
                   help=f"control rate, Hz, {NODE_RATE_MIN_HZ:g}..{P.CONTROL_RATE_HZ:g}")
    p.add_argument("--clock", choices=["realtime", "lockstep"], default="realtime",
                   help="realtime: fixed-rate loop; lockstep: one step per motor feedback tick")
    add_spin_option(p)
    p.add_argument("--duration", type=wall_duration, default=None,
                   help="stop after this many seconds of node time (default: until Ctrl-C; inprocess: "
                        f"the script's, at most {SIM_DURATION_MAX_S:g} s)")
    p.add_argument("--idle-timeout", type=wait_s, default=5.0,
                   help="lockstep: stop after this much wall time without motor feedback once the robot "
                        "has been heard (before: 120 s, for a robot slow to start), s")
    p.add_argument("--no-heartbeat", action="store_true",
                   help="do not require the robot side's heartbeat (bench use without a PMU-like peer)")
    p.add_argument("--soft-start", type=in_range(0.0, SOFT_START_MAX_S), default=P.SAFETY.soft_start_s,
                   help=f"gain ramp-in time on entering impedance/PD mode, s, 0..{SOFT_START_MAX_S:g}")
    p.add_argument("--state-every", type=in_range(1, 1000, kind=int), default=1,
                   help="publish spine state every N ticks")
    p.add_argument("--summary", type=output_file(), default=None, metavar="PATH",
                   help="write a JSON summary of the run here (checked before the run starts)")
    rt = p.add_argument_group("real time (torso computer; see docs 'Running on a PREEMPT_RT kernel')")
    rt.add_argument("--cpu", type=nonnegative_int, default=None,  # realtime.apply checks that it exists
                    help="pin the node to this CPU (isolate it with isolcpus=N on the kernel command line)")
    rt.add_argument("--rt-priority", type=in_range(1, 99, kind=int), default=None,
                    help="run under SCHED_FIFO at this priority, 1..99 (needs root, CAP_SYS_NICE or rtprio)")
    rt.add_argument("--lock-memory", action="store_true",
                    help="lock the process's memory (mlockall) so no page fault stalls a tick; best effort")
    add_wake_latency_option(rt)
    p.set_defaults(wake_latency_us=WAKE_LATENCY_BY_BACKEND)
    add_can_options(p)
    add_experiment_args(p)
    p.set_defaults(func=run)


class _Stopped(Exception):
    """A signal arrived during start-up: leave through the clean-up, exit as the signal asks."""


# Ctrl-C before `run` installs its handler (while the CLI imports pinocchio, numba, lcm: up to ~1 s) is a
# KeyboardInterrupt raised wherever the interpreter is, and an extension's import can swallow it (issue 31:
# a node signalled 0.3 s after spawn kept running). The signal is also recorded here, as the default handler
# would raise it, so `run` ends at once whatever became of the exception.
_EARLY_SIGNALS: list[int] = []


def _record_and_interrupt(signum: int, frame: object) -> None:
    _EARLY_SIGNALS.append(signum)
    raise KeyboardInterrupt


# only in a `sparc-quad spine-node` process (a program or a test importing the CLI keeps Python's handler)
if ("spine-node" in sys.argv[1:] and threading.current_thread() is threading.main_thread()
        and signal.getsignal(signal.SIGINT) is signal.default_int_handler):
    signal.signal(signal.SIGINT, _record_and_interrupt)


@contextlib.contextmanager
def _node_signals() -> Iterator[tuple[Stop, list[bool]]]:
    """SIGINT/SIGTERM for the whole command, from its first line: recorded in a Stop event that every start-up
    step and the loop check; raised as KeyboardInterrupt only while `raising[0]` is True (the motor
    handshake's waits), never inside an extension's start-up code that might swallow it."""
    stop = Stop()
    raising = [False]
    if _EARLY_SIGNALS:
        stop.signum = _EARLY_SIGNALS[0]
        stop.set()
        _EARLY_SIGNALS.clear()  # consumed by this run

    def handler(signum, frame) -> None:
        if stop.signum is None:
            stop.signum = signum
        stop.set()
        if raising[0]:
            raise KeyboardInterrupt

    old = {sig: signal.signal(sig, handler) for sig in (signal.SIGINT, signal.SIGTERM)}
    try:
        yield stop, raising
    finally:
        for sig, h in old.items():
            signal.signal(sig, h)


def _check(stop: Stop) -> None:
    if stop.is_set():
        raise _Stopped


class _ByBackend:
    """--wake-latency-us not given: held at 0 us for the robot's motors (`--motors can`), where the node is
    the real-time process (docs/performance.md); off for the simulated backends, which run beside a
    simulator on a shared machine and would keep every CPU of it out of deep idle (issue 31)."""

    def __str__(self) -> str:
        return f"{WAKE_LATENCY_DEFAULT_US} with --motors can, off otherwise"


WAKE_LATENCY_BY_BACKEND = _ByBackend()


def wake_latency(args: argparse.Namespace) -> int | None:
    """The wake-latency bound to hold, us (None: none), after the per-backend default."""
    if isinstance(args.wake_latency_us, _ByBackend):
        return WAKE_LATENCY_DEFAULT_US if args.motors == "can" else None
    return args.wake_latency_us


def _node_config(args: argparse.Namespace):
    from spine_module.node import NodeConfig

    return NodeConfig(rate_hz=args.rate, state_every=args.state_every,
                      safety=SafetyConfig(soft_start_s=args.soft_start,
                                          heartbeat_required=not args.no_heartbeat))


def _bus_options(args: argparse.Namespace) -> dict[str, object]:
    """The chosen backend's options as keyword arguments (see spine_module.buses.registry)."""
    if args.motors == "can":  # the config's timeouts are judged at the node's own rate
        return {**can_options(args), "rate_hz": args.rate}
    if args.motors == "lcm":
        return {"url": args.lcm_url, "spin_s": args.spin_us * 1e-6 if args.clock == "lockstep" else 0.0}
    return {}


def _make_bus(args: argparse.Namespace, lc):
    if args.motors != "can":
        try:
            return registry.make_bus(args.motors, lc=lc, **_bus_options(args))
        except ValueError as exc:
            raise BadInput(str(exc)) from exc
    from sparc_quad.cli.can_open import bus_open_error, open_errors, quiet_repeats
    from spine_module.buses.cybergear.config import ConfigError

    quiet_repeats()
    try:
        return registry.make_bus("can", lc=lc, **_bus_options(args))
    except ConfigError as exc:
        raise BadInput(str(exc)) from exc
    except open_errors() as exc:
        raise bus_open_error(exc, args.can_interface, args.can_channel) from exc


def run(args: argparse.Namespace) -> int:
    with _node_signals() as (stop, raising):
        try:
            return _run(args, stop, raising)
        except (_Stopped, KeyboardInterrupt):  # a signal during start-up (or the in-process run): what was
            # opened is closed (motors stopped), then exit as the signal asks
            log.info("spine-node: stopped by signal %s", stop.signum)
            return stop.exit_code() if stop.is_set() else 130


def _run(args: argparse.Namespace, stop: Stop, raising: list[bool]) -> int:
    _check(stop)
    import lcm

    from spine_module.node import Controllers, LcmNodeIO, SpineNode, realtime, run_lockstep, run_realtime

    _check(stop)
    try:
        rt_done = realtime.apply(realtime.RtOptions(cpu=args.cpu, rt_priority=args.rt_priority,
                                                    lock_memory=args.lock_memory,
                                                    wake_latency_us=wake_latency(args)))
        for line in rt_done:
            log.log(logging.WARNING if " not " in line else logging.INFO, "spine-node: %s", line)
    except realtime.RtSetupError as exc:
        raise BadInput(str(exc)) from exc
    _check(stop)
    if args.motors == "inprocess":  # a simulation in this thread: a signal interrupts it where it is
        raising[0] = True
        return _run_inprocess(args)
    try:
        lc = lcm.LCM(args.lcm_url)
    except RuntimeError as exc:
        raise BadInput(f"cannot open LCM at {args.lcm_url!r} (a multicast route is needed, see docs): "
                       f"{exc}") from exc
    io = LcmNodeIO(lc)
    peers = io.listen_for_nodes(NODE_LISTEN_S)  # before this node publishes or opens its motors
    if stop.is_set():
        io.close()
        raise _Stopped
    if peers:
        io.close()
        raise BadInput("another spine node is running on this LCM URL (" + ", ".join(
            f"{sender!r} instance {inst:#x}" for inst, sender in peers.items()) + f", {args.lcm_url!r}): two "
            "nodes would both command the motors; stop it first")
    _check(stop)
    bus = _make_bus(args, lc)
    try:
        _check(stop)
        node = SpineNode(Controllers.default(), bus, io, _node_config(args))
        # before start(): a full collection holds the interpreter for tens of ms, during which nothing could
        # feed the motors that start() enabled (their CAN timeout is 50 ms)
        rt_done.append(realtime.freeze_startup_objects())
        _check(stop)
        try:
            raising[0] = True  # the handshake waits: a signal ends them (start() stops what it enabled)
            _check(stop)
            bus.start()
        finally:
            raising[0] = False
        _check(stop)
    except MotorBusError as exc:  # e.g. a motor that did not answer: say which, stop the others, exit
        log.error("motor bus start-up failed: %s", exc)
        bus.shutdown()
        io.close()
        if isinstance(exc, MotorSetupError):  # the robot as wired cannot run (two motors on one id): exit 2
            raise BadInput(f"motor bus start-up refused: {exc}") from exc
        return 1
    except (KeyboardInterrupt, _Stopped):  # a signal while starting: the motors enabled so far are stopped
        bus.shutdown()
        io.close()
        raise _Stopped from None
    log.info("spine-node: motors=%s clock=%s rate=%.0f Hz", args.motors, args.clock, args.rate)
    try:
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
               # sequence numbers that went back, repeated or jumped, per channel (node.io.SEQ_RESYNC)
               "seq_anomalies": io.inbox.seq_anomalies, "stalls": node.stalls,
               "drained_at_start": node.drained_at_start,
               "last_faults": node.state.faults.name or "NONE", "last_rejected": node.rejected,
               "repeated_ticks": node.repeated_ticks,
               # lockstep: ticks whose torso state came after their feedback, and those run without it
               "lockstep_torso_waits": io.torso_waits, "lockstep_torso_missing": node.lockstep_torso_missing,
               "lockstep_opening_incomplete": node.lockstep_opening_incomplete,
               "bus_faults": list(getattr(bus, "latched_faults", [])),  # latched in the motor backend
               # messages superseded by a newer one before the node looked (a flood shows here)
               "dropped": {**io.inbox.dropped, **({"SPARC_MOTOR_FEEDBACK": bus.dropped}
                                                  if hasattr(bus, "dropped") else {})}}
    latched = _latched(node, summary["bus_faults"])
    summary["ended_latched"] = latched
    print(json_text(summary))
    if args.summary is not None:
        try:
            args.summary.parent.mkdir(parents=True, exist_ok=True)
            args.summary.write_text(json_text(summary, indent=2))
        except OSError as exc:  # checked at start; it changed during the run (the summary is printed above)
            raise BadInput(f"--summary {args.summary}: {exc.strerror or exc}") from exc
    if latched:
        log.error("spine-node: the run ended with a latched fault: %s", latched)
        return EXIT_LATCHED
    return stop.exit_code()


def _latched(node, bus_faults: list[str]) -> str:
    """What was latched when the run ended (empty: nothing): the node's latches other than a commanded
    E-stop, and the motor backend's bus faults. Such a run is not a success, whatever stopped it."""
    from spine_module.messages import Fault

    bits = node.safety.latched & ~Fault.ESTOP
    parts = [bits.name] if bits else []
    return "; ".join(parts + list(bus_faults))


def _run_inprocess(args: argparse.Namespace) -> int:
    from sparc_quad.experiments.stats import stiffness_from_states
    from sparc_quad.robot_side.bench import run_inprocess

    if args.clock != "lockstep":
        log.info("--motors inprocess always runs in lockstep (robot and node in one thread)")
    robot, states = run_inprocess(script(args), _node_config(args), plant=plant(args), seed=args.seed)
    out = {"ticks": robot.k, "final_x": [float(v) for v in states[-1].x] if states else None}
    if args.experiment == "static" and states:
        out["k_x_commanded_n_m"] = float(args.kx)
        out["k_hat_n_m"] = stiffness_from_states(states)
    print(json_text(out))
    if "k_hat_n_m" in out:
        k_hat, k_cmd = out["k_hat_n_m"], out["k_x_commanded_n_m"]
        print(f"static push-pull: fitted k_x {k_hat:.1f} N/m against the commanded {k_cmd:.1f} N/m "
              f"({100 * (k_hat / k_cmd - 1):+.1f} %)", file=sys.stderr)
    return 0
