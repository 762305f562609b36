"""`sparc-quad motors`: CyberGear motors on a CAN bus: scan, status, enable, disable, zero, set-id, emulate.

Every action takes the CAN options spelled as on `spine-node --motors can` (`--can-interface`,
`--can-channel`, `--can-bitrate`; `--can-log PATH` records the session's frames with python-can: `.asc`,
`.blf`, `.log`, `.csv` by suffix). Motor ids come from `--ids`
or from the per-joint config (`--motor-config`, default the packaged motors.toml).

`watchdog` is the fallback for motors whose own CAN timeout cannot be set: it watches the node's frames on
the bus and sends stop frames to every motor when they stop while the motors run (see
`spine_module.buses.cybergear.watchdog`).

`emulate` answers as motors `--ids` on the bus until SIGINT/SIGTERM: `--plant free` (an inertia per motor,
real time) or `--plant bench` (the pybullet bench spine), `--lockstep` to step the plant once per full set
of commands instead of in real time.
"""

from __future__ import annotations

import argparse
import json
import signal
import sys
import threading

from sparc_quad.cli.args import add_can_options, in_range, positive_float

ACTIONS = ("scan", "status", "enable", "disable", "zero", "set-id", "emulate", "watchdog")


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("motors", help="CyberGear motors on CAN: scan, status, enable, disable, zero, set-id, "
                                      "emulate, watchdog")
    p.add_argument("action", choices=ACTIONS)
    add_can_options(p)
    p.add_argument("--host-id", type=_can_id, default=None,
                   help="this host's CAN id (default: from the motor config)")
    p.add_argument("--ids", default=None, help="motor ids, e.g. 1,2,3 (default: from the motor config; "
                                               "scan: 1..127)")
    p.add_argument("--timeout", type=positive_float, default=0.5, help="seconds to wait for replies")
    p.add_argument("--clear-fault", action="store_true", help="disable: also clear latched faults")
    p.add_argument("--new-id", type=in_range(1, 127, kind=int), default=None,
                   help="set-id: the new id (1..127); --ids: the old one")
    p.add_argument("--yes", action="store_true", help="enable/zero/set-id: do it without asking")
    p.add_argument("--plant", choices=("free", "bench"), default="free",
                   help="emulate: physics behind the motors")
    p.add_argument("--lockstep", action="store_true", help="emulate: one plant step per full command set")
    p.add_argument("--duration", type=positive_float, default=None,
                   help="emulate, watchdog: stop after this many seconds")
    p.add_argument("--deadline", type=positive_float, default=None,
                   help="watchdog: stop the motors after this long without a host frame (s; default: the "
                        "config's can_timeout_s, or 0.05 if that is 0)")
    p.set_defaults(func=run)


def _can_id(text: str) -> int:
    """A CAN id, decimal or 0x-hex, 0..255."""
    try:
        value = int(text, 0)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected an integer (e.g. 253 or 0xFD), got {text!r}") from None
    if not 0 <= value <= 0xFF:
        raise argparse.ArgumentTypeError(f"must be in [0, 255], got {text!r}")
    return value


def _ids(args: argparse.Namespace, cfg) -> list[int]:
    from sparc_quad.sim.cybergear_emulator import parse_ids
    if args.ids:
        return parse_ids(args.ids)
    return list(range(1, 128)) if args.action == "scan" else list(cfg.ids)


def run(args: argparse.Namespace) -> int:
    from spine_module.buses.cybergear import protocol as P
    from spine_module.buses.cybergear.config import ConfigError, load_config
    from spine_module.buses.cybergear.driver import open_bus

    try:
        cfg = load_config(args.motor_config)
    except ConfigError as exc:
        print(f"motors: {exc}", file=sys.stderr)
        return 2
    bitrate = args.can_bitrate or cfg.bitrate
    host = cfg.host_id if args.host_id is None else args.host_id
    ids = _ids(args, cfg)
    if args.action == "emulate":
        return _emulate(args, ids, host, cfg, bitrate)
    if args.action == "watchdog":
        return _watchdog(args, ids, host, cfg, bitrate)
    if args.action in ("enable", "zero", "set-id") and not args.yes:
        if not sys.stdin.isatty():  # a pipe or a script cannot answer the question: refuse, act on --yes only
            print(f"motors {args.action}: stdin is not a terminal, so nobody can confirm; pass --yes to "
                  f"{args.action} motor(s) {ids} without asking", file=sys.stderr)
            return 2
        answer = input(f"{args.action} motor(s) {ids} on {args.can_interface}:{args.can_channel}? [y/N] ")
        if answer.strip().lower() not in ("y", "yes"):
            return 1
    from spine_module.buses.cybergear import tools

    bus = open_bus(args.can_interface, args.can_channel, bitrate)
    with tools.Session(bus, host, cfg.ranges, args.can_log) as s:
        if args.action == "scan":
            found = tools.scan(s, ids, args.timeout)
            if not found:
                print("no motors answered")
                return 1
            print(f"{'CAN id':>6}  MCU uid")
            for i, uid in sorted(found.items()):
                print(f"{i:>6}  {uid.hex()}")
            return 0
        if args.action == "status":
            sts = tools.status(s, ids, args.timeout)
            missing = [i for i, st in sts.items() if st.uid is None and not st.params]
            for i, st in sts.items():
                if i in missing:
                    print(f"motor {i}: no answer")
                    continue
                params = ", ".join(f"{k}={v:.4g}" if isinstance(v, float) else f"{k}={v}"
                                   for k, v in st.params.items())
                print(f"motor {i}: uid {st.uid.hex() if st.uid else '?'}; {params}")
            return 1 if missing else 0
        if args.action == "set-id":
            if len(ids) != 1 or args.new_id is None:
                print("set-id needs exactly one --ids (the current id) and --new-id", file=sys.stderr)
                return 2
            uid = tools.set_id(s, ids[0], args.new_id, args.timeout)
            outcome = f"answered, uid {uid.hex()}" if uid else "no answer"
            print(f"motor {ids[0]} -> {args.new_id}: {outcome}")
            return 0 if uid else 1
        kind = args.action
        got = tools.command(s, ids, kind, args.timeout, clear_fault=args.clear_fault)
        for i, fb in got.items():
            if fb is None:
                print(f"motor {i}: no answer")
            else:
                faults = ", ".join(P.describe_feedback_faults(fb.fault_bits)) or "none"
                print(f"motor {i}: mode {P.MotorMode(fb.mode).name}, position {fb.position:+.4f} rad, "
                      f"faults {faults}")
        return 0 if all(fb is not None for fb in got.values()) else 1


def _emulate(args: argparse.Namespace, ids: list[int], host: int, cfg, bitrate: int) -> int:
    from sparc_quad.sim.cybergear_emulator import CyberGearEmulator, FreePlant
    from spine_module.buses.cybergear.driver import open_bus

    stop = threading.Event()

    def on_signal(signum, frame):
        stop.set()

    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, on_signal)
    bus = open_bus(args.can_interface, args.can_channel, bitrate)
    world = None
    try:
        if args.plant == "bench":
            from sparc_quad.sim.bench_world import BenchWorld
            from sparc_quad.sim.cybergear_bench import BenchCoupling
            world = BenchWorld()
            plant = BenchCoupling(world, ids)
        else:
            plant = FreePlant(ids)
        log = None
        if args.can_log:
            import can
            log = can.Logger(args.can_log)
        emu = CyberGearEmulator(bus, ids, plant, host_id=host, ranges=cfg.ranges, lockstep=args.lockstep,
                                log=log)
        emu.keep_log = False
        print(f"emulating CyberGear motor(s) {ids} on {args.can_interface}:{args.can_channel} "
              f"({args.plant} plant{', lockstep' if args.lockstep else ''}); Ctrl-C to stop", flush=True)
        if args.lockstep:  # the plant steps on commands; the motors' CAN timeout still runs on the clock
            t_end = None if args.duration is None else emu.clock() + args.duration
            while not stop.wait(0.001) and (t_end is None or emu.clock() < t_end):
                emu.check_can_timeouts()
        else:
            timer = threading.Timer(args.duration, stop.set) if args.duration else None
            if timer:
                timer.start()
            emu.run(stop)
            if timer:
                timer.cancel()
        emu.shutdown()
        print(f"emulator: {len(emu.rejected)} frames rejected, {len(emu.refused)} commands refused, "
              f"{emu.sent} frames sent, {emu.steps} plant steps", flush=True)
        # the CAN-timeout trips in the emulator's clock, for tests and people: one JSON line
        print(json.dumps({"can_timeout_trips": [
            {"motor": i, "can_timeout_s": emu.motors[i].can_timeout_s() if i in emu.motors else None,
             "last_frame_s": t0, "tripped_s": t1, "last_torque_s": emu.motors[i].last_torque_s}
            for i, t0, t1 in emu.timeout_trips],
            "motors": {i: {"mode": int(m.mode), "last_frame_s": m.last_rx_s, "last_torque_s": m.last_torque_s}
                       for i, m in emu.motors.items()}, "clock_s": emu.clock()}), flush=True)
    finally:
        bus.shutdown()
        if world is not None:
            world.close()
    return 0


def _watchdog(args: argparse.Namespace, ids: list[int], host: int, cfg, bitrate: int) -> int:
    import can

    from spine_module.buses.cybergear.driver import open_bus
    from spine_module.buses.cybergear.watchdog import DEADLINE_MAX_S, DEADLINE_MIN_S, StopWatchdog

    deadline = args.deadline if args.deadline is not None else (cfg.can_timeout_s or 0.05)
    if not DEADLINE_MIN_S <= deadline <= DEADLINE_MAX_S:
        print(f"motors watchdog: --deadline must be in [{DEADLINE_MIN_S:g}, {DEADLINE_MAX_S:g}] s (a longer "
              f"one never fires in time), got {deadline:g}", file=sys.stderr)
        return 2
    stop = threading.Event()
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, lambda signum, frame: stop.set())
    bus = open_bus(args.can_interface, args.can_channel, bitrate)
    dog = StopWatchdog(bus, ids, host, deadline)
    notifier = can.Notifier(bus, [dog.on_message], timeout=0.05)
    print(f"watchdog: motor(s) {ids} on {args.can_interface}:{args.can_channel}, "
          f"deadline {deadline * 1e3:g} ms", flush=True)
    try:
        timer = threading.Timer(args.duration, stop.set) if args.duration else None
        if timer:
            timer.start()
        dog.run(stop)
        if timer:
            timer.cancel()
    finally:
        notifier.stop()
        bus.shutdown()
    print(json.dumps({"watchdog_fired": [{"last_host_frame_s": a, "fired_s": b} for a, b in dog.fired]}),
          flush=True)
    return 0
