"""`sparc-quad motors`: CyberGear motors on a CAN bus: scan, status, enable, disable, zero, set-id, emulate.

Every action takes the CAN options spelled as on `spine-node --motors can` (`--can-interface`,
`--can-channel`, `--can-bitrate`; `--can-log PATH` records the session's frames with python-can: `.asc`,
`.blf`, `.log`, `.csv` by suffix). Motor ids come from `--ids`
or from the per-joint config (`--motor-config`, default the packaged motors.toml).

`watchdog` is the fallback for motors whose own CAN timeout cannot be set: it watches the node's frames on
the bus and sends stop frames to every motor when they stop while the motors run (see
`spine_module.buses.cybergear.watchdog`).

`emulate` answers as motors `--ids` on the bus until SIGINT/SIGTERM: `--load free` (an inertia per motor,
real time) or `--load bench` (the pybullet bench spine), `--lockstep` to step the load once per full set
of commands instead of in real time. (`--plant` is the old spelling of `--load`.)
"""

from __future__ import annotations

import argparse
import json
import sys
import threading

from sparc_quad.cli.args import WALL_DURATION_MAX_S, add_can_options, id_list, in_range, wall_duration
from sparc_quad.cli.can_open import open_can
from sparc_quad.cli.errors import BadInput, bad_input
from sparc_quad.cli.parser import RawDescriptionFormatter
from sparc_quad.cli.signals import stop_after, stop_on_signals
from spine_module.buses.cybergear.watchdog import DEADLINE_MAX_S, DEADLINE_MIN_S

ACTIONS = ("scan", "status", "enable", "disable", "zero", "set-id", "emulate", "watchdog")
MOTOR_ID_MAX = 0x7F  # CyberGear ids are 7 bits; 0 is not a motor (protocol.FACTORY_MOTOR_ID is 127)
REPLY_TIMEOUT_MAX_S = 60.0  # a motor answers within ms; a longer wait is a typo


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("motors", help="CyberGear motors on CAN: scan, status, enable, disable, zero, set-id, "
                                      "emulate, watchdog",
                       description=__doc__.split("\n\n", 1)[1] if __doc__ else None,
                       formatter_class=RawDescriptionFormatter)
    p.add_argument("action", choices=ACTIONS, help="what to do (see above)")
    add_can_options(p)
    p.add_argument("--host-id", type=_can_id, default=None,
                   help="this host's CAN id, 0..255 (default: from the motor config)")
    p.add_argument("--ids", type=id_list(1, MOTOR_ID_MAX), default=None,
                   help=f"motor ids, e.g. 1,2,3, each 1..{MOTOR_ID_MAX}, distinct (default: from the motor "
                        f"config; scan: 1..{MOTOR_ID_MAX})")
    p.add_argument("--timeout", type=in_range(0.0, REPLY_TIMEOUT_MAX_S, lo_open=True), default=0.5,
                   help=f"seconds to wait for replies, up to {REPLY_TIMEOUT_MAX_S:g}")
    p.add_argument("--clear-fault", action="store_true", help="disable: also clear latched faults")
    p.add_argument("--new-id", type=in_range(1, MOTOR_ID_MAX, kind=int), default=None,
                   help=f"set-id: the new id (1..{MOTOR_ID_MAX}); --ids: the old one")
    p.add_argument("--yes", action="store_true", help="enable/zero/set-id: do it without asking")
    p.add_argument("--load", "--plant", dest="load", choices=("free", "bench"), default="free",
                   help="emulate: what the motors drive (bench needs the [sim] extra; --plant: old spelling)")
    p.add_argument("--lockstep", action="store_true", help="emulate: one load step per full command set")
    p.add_argument("--duration", type=wall_duration, default=None,
                   help=f"emulate, watchdog: stop after this many seconds, up to {WALL_DURATION_MAX_S:g} "
                        "(default: until Ctrl-C)")
    p.add_argument("--deadline", type=in_range(DEADLINE_MIN_S, DEADLINE_MAX_S), default=None,
                   help=f"watchdog: stop the motors after this long without a host frame, s, "
                        f"{DEADLINE_MIN_S:g}..{DEADLINE_MAX_S:g} (a longer one never fires in time) "
                        "(default: the config's can_timeout_s, or 0.05 if that is 0)")
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
    if args.ids:
        return list(args.ids)
    return list(range(1, MOTOR_ID_MAX + 1)) if args.action == "scan" else list(cfg.ids)


def run(args: argparse.Namespace) -> int:
    from spine_module.buses.cybergear import protocol as P
    from spine_module.buses.cybergear.config import ConfigError, load_config

    with bad_input(ConfigError):
        cfg = load_config(args.motor_config)
    bitrate = args.can_bitrate or cfg.bitrate
    host = cfg.host_id if args.host_id is None else args.host_id
    ids = _ids(args, cfg)
    if args.action == "emulate":
        return _emulate(args, ids, host, cfg, bitrate)
    if args.action == "watchdog":
        return _watchdog(args, ids, host, cfg, bitrate)
    if args.action in ("enable", "zero", "set-id") and not args.yes:
        if not sys.stdin.isatty():  # a pipe or a script cannot answer the question: refuse, act on --yes only
            raise BadInput(f"stdin is not a terminal, so nobody can confirm; pass --yes to {args.action} "
                           f"motor(s) {ids} without asking")
        answer = input(f"{args.action} motor(s) {ids} on {args.can_interface}:{args.can_channel}? [y/N] ")
        if answer.strip().lower() not in ("y", "yes"):
            return 1
    from spine_module.buses.cybergear import tools

    if args.action == "set-id" and (len(ids) != 1 or args.new_id is None):
        raise BadInput("set-id needs exactly one --ids (the current id) and --new-id")
    bus = open_can(args.can_interface, args.can_channel, bitrate, dict(args.can_option))
    with tools.Session(bus, host, cfg.ranges, None if args.can_log is None else str(args.can_log)) as s:
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


def _load_maker(args: argparse.Namespace, ids: list[int]):
    """A function making (world or None, load); its modules are imported now, before any bus opens, so a
    missing extra is named before anything happens on the bus."""
    from sparc_quad.sim.cybergear_emulator import FreeLoad

    if args.load == "free":
        return lambda: (None, FreeLoad(ids))
    from sparc_quad.sim.bench_world import BenchWorld
    from sparc_quad.sim.cybergear_bench import BenchCoupling

    def bench():
        world = BenchWorld()
        return world, BenchCoupling(world, ids)

    return bench


def _emulate(args: argparse.Namespace, ids: list[int], host: int, cfg, bitrate: int) -> int:
    make_load = _load_maker(args, ids)
    with stop_on_signals() as stop:
        bus = open_can(args.can_interface, args.can_channel, bitrate, dict(args.can_option))
        world = None
        try:
            world, load = make_load()
            _serve(args, ids, host, cfg, bus, load, stop)
        finally:
            bus.shutdown()
            if world is not None:
                world.close()
    return stop.exit_code()


def _serve(args: argparse.Namespace, ids: list[int], host: int, cfg, bus, load,
           stop: threading.Event) -> None:
    """Answer as the motors until `stop` or --duration; print what happened."""
    from sparc_quad.sim.cybergear_emulator import CyberGearEmulator

    log = None
    if args.can_log:
        import can
        log = can.Logger(str(args.can_log))
    emu = CyberGearEmulator(bus, ids, load, host_id=host, ranges=cfg.ranges, lockstep=args.lockstep,
                            log=log)
    emu.keep_log = False
    print(f"emulating CyberGear motor(s) {ids} on {args.can_interface}:{args.can_channel} "
          f"({args.load} load{', lockstep' if args.lockstep else ''}); Ctrl-C to stop", flush=True)
    if args.lockstep:  # the load steps on commands; the motors' CAN timeout still runs on the clock
        t_end = None if args.duration is None else emu.clock() + args.duration
        while not stop.wait(0.001) and (t_end is None or emu.clock() < t_end):
            emu.check_can_timeouts()
    else:
        with stop_after(stop, args.duration):
            emu.run(stop)
    emu.shutdown()
    print(f"emulator: {len(emu.rejected)} frames rejected, {len(emu.refused)} commands refused, "
          f"{emu.sent} frames sent, {emu.steps} load steps", flush=True)
    # the CAN-timeout trips in the emulator's clock, for tests and people: one JSON line
    print(json.dumps({"can_timeout_trips": [
        {"motor": i, "can_timeout_s": emu.motors[i].can_timeout_s() if i in emu.motors else None,
         "last_frame_s": t0, "tripped_s": t1, "last_torque_s": emu.motors[i].last_torque_s}
        for i, t0, t1 in emu.timeout_trips],
        "motors": {i: {"mode": int(m.mode), "last_frame_s": m.last_rx_s, "last_torque_s": m.last_torque_s}
                   for i, m in emu.motors.items()}, "clock_s": emu.clock()}), flush=True)


def _watchdog(args: argparse.Namespace, ids: list[int], host: int, cfg, bitrate: int) -> int:
    with stop_on_signals() as stop:
        return _watch(args, ids, host, cfg, bitrate, stop)


def _watch(args: argparse.Namespace, ids: list[int], host: int, cfg, bitrate: int, stop) -> int:
    import can

    from spine_module.buses.cybergear.watchdog import StopWatchdog

    deadline = args.deadline if args.deadline is not None else (cfg.can_timeout_s or 0.05)
    if not DEADLINE_MIN_S <= deadline <= DEADLINE_MAX_S:  # from the config: --deadline is checked by its type
        raise BadInput(f"watchdog deadline {deadline:g} s (the config's can_timeout_s) must be in "
                       f"[{DEADLINE_MIN_S:g}, {DEADLINE_MAX_S:g}] s; pass --deadline")
    bus = open_can(args.can_interface, args.can_channel, bitrate, dict(args.can_option))
    dog = StopWatchdog(bus, ids, host, deadline)
    notifier = can.Notifier(bus, [dog.on_message], timeout=0.05)
    print(f"watchdog: motor(s) {ids} on {args.can_interface}:{args.can_channel}, "
          f"deadline {deadline * 1e3:g} ms", flush=True)
    try:
        with stop_after(stop, args.duration):
            dog.run(stop)
    finally:
        notifier.stop()
        bus.shutdown()
    print(json.dumps({"watchdog_fired": [{"last_host_frame_s": a, "fired_s": b} for a, b in dog.fired]}),
          flush=True)
    return stop.exit_code()
