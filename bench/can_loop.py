"""Control loop over CAN with 3 emulated CyberGears: achieved rate, frames per second each way, bus load.

Two loops:
- "max": the emulator in lockstep (one plant step per full command set) on python-can's `virtual` bus in
  this process; the loop runs as fast as the host allows: receive feedback of 3 motors, send 3
  operation-control frames;
- "paced": the loop paced at --rate-hz on an absolute schedule (the node's `RealTimeClock`: a late cycle
  does not move the later deadlines; it is counted as an overrun and the time is made up), the emulator
  free-running. With --emulator process (the default) the emulator is `sparc-quad motors emulate` in its
  own process on `udp_multicast`, inside a private network namespace this script makes (re-running itself
  under `unshare -n`), so it shares no interpreter lock with the loop; --emulator thread keeps it on a
  thread of this process (`virtual` bus).
Beside the paced loop it runs the host ceiling: the same clock and schedule with no bus, each cycle doing
a fixed pure-Python workload calibrated to the CPU the paced loop spent per cycle (process CPU time, all
threads, minus what the bare clock spends). Cycles that loop loses are lost to the host (other jobs, the
hypervisor slowing this VM's CPUs), not to CAN: on this project's shared VM a 100 us workload gets
~1-2 ms slower now and then, and a loop doing ~300 us of Python per cycle loses ~2 % of its cycles.
It also prints the bus-load model (8-byte extended frames, worst-case stuffing) for 3 motors at --rate-hz
on a 1 Mbit/s bus, and the highest rate that keeps it under the project's 80 % limit.
Goal: 3 motors, 1 kHz +-1 % over 10 s.

usage: python bench/can_loop.py [--seconds 10] [--rate-hz 1000] [--emulator process|thread] [--json PATH]
"""

from __future__ import annotations

import argparse
import json
import logging
import math
import os
import shutil
import subprocess
import sys
import threading
import time
import uuid
from pathlib import Path

import can
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from sparc_quad.sim.cybergear_emulator import CyberGearEmulator
from spine_module.buses.base import MotorBusError, MotorCommand
from spine_module.buses.cybergear import CanMotorBus, bus_load, load_config, max_loop_rate_hz
from spine_module.buses.cybergear.plausibility import PlausibilityLimits
from spine_module.node.clocks import PeriodStats, RealTimeClock
from spine_module.node.realtime import RtOptions, RtSetupError, apply, freeze_startup_objects

ROOT = Path(__file__).resolve().parents[1]
# the emulators' free inertias under a constant torque are not a spine: they drift past its joint ranges,
# so the feedback's range check is off here (its step and velocity checks stay on)
FREE_PLANT = PlausibilityLimits(check_range=False)


def _rig(lockstep: bool):
    channel = f"bench-{uuid.uuid4().hex[:8]}"
    ebus = can.Bus(interface="virtual", channel=channel)
    emu = CyberGearEmulator(ebus, (1, 2, 3), lockstep=lockstep)
    emu.keep_log = False
    cfg = load_config().with_(silent_timeout_s=1.0, can_timeout_s=1.0)  # tolerate a loaded host
    mb = CanMotorBus(cfg, interface="virtual", channel=channel, plausibility=FREE_PLANT)
    mb.start()
    mb.receive(1.0)
    return ebus, emu, mb


def run_max(seconds: float) -> dict:
    ebus, emu, mb = _rig(lockstep=True)
    cmd = MotorCommand(tau_ff=np.full(3, 0.1), kd=np.full(3, 0.05))
    tx0, rx0 = mb.tx_frames, mb.rx_frames
    n, t0 = 0, time.perf_counter()
    try:
        while time.perf_counter() - t0 < seconds:
            mb.send(cmd)
            if mb.receive(1.0) is None:
                raise RuntimeError("feedback lost")
            n += 1
        dt = time.perf_counter() - t0
        return {"cycles": n, "seconds": dt, "rate_hz": n / dt, "tx_frames_per_s": (mb.tx_frames - tx0) / dt,
                "rx_frames_per_s": (mb.rx_frames - rx0) / dt}
    finally:
        mb.stop()
        mb.shutdown()
        emu.shutdown()
        ebus.shutdown()


def _paced_loop(mb, seconds: float, rate_hz: float) -> dict:
    """Receive the newest feedback, send one command set, wait for the next absolute deadline."""
    cmd = MotorCommand(tau_ff=np.full(3, 0.1), kd=np.full(3, 0.05))
    freeze_startup_objects()  # as spine-node does before its loop: no long gen-2 collection mid-run
    clock = RealTimeClock(rate_hz)
    cpu0, main0 = time.process_time(), time.thread_time()
    tx0, rx0 = mb.tx_frames, mb.rx_frames
    n, stale = 0, 0
    error = None
    stats = PeriodStats(1.0 / rate_hz)
    t0 = time.monotonic()
    while True:
        now = clock.wait()
        if now > seconds:
            break
        stats.mark(time.monotonic())
        fb = None
        try:
            while True:
                got = mb.receive(0.0)
                if got is None:
                    break
                fb = got
            stale += fb is None
            mb.send(cmd)
        except MotorBusError as exc:  # e.g. a motor reset by its CAN timeout after a long stall
            error = str(exc)
            break
        n += 1
    dt = time.monotonic() - t0
    cpu, main = time.process_time() - cpu0, time.thread_time() - main0
    return {"cycles": n, "seconds": dt, "rate_hz": n / dt, "target_hz": rate_hz,
            "rate_ratio": n / dt / rate_hz,
            "cpu_per_cycle_us": 1e6 * cpu / max(n, 1), "main_thread_cpu_per_cycle_us": 1e6 * main / max(n, 1),
            "cycles_without_fresh_feedback": stale, "overruns": clock.overruns, "rephases": clock.rephases,
            "period": stats.histogram.summary(), "bus_error": error,
            "tx_frames_per_s": (mb.tx_frames - tx0) / dt, "rx_frames_per_s": (mb.rx_frames - rx0) / dt}


def _work_unit() -> int:
    """A fixed amount of pure-Python work (no allocation that could trigger the garbage collector)."""
    s = 0
    for i in range(200):
        s += i * i
    return s


def _unit_cpu_s() -> float:
    """CPU time of one `_work_unit` at full speed: the fastest of 20 batches of 100."""
    best = math.inf
    for _ in range(20):
        c0 = time.thread_time()
        for _ in range(100):
            _work_unit()
        best = min(best, (time.thread_time() - c0) / 100)
    return best


def _clock_loop(seconds: float, rate_hz: float, units: int) -> dict:
    clock = RealTimeClock(rate_hz)
    stats = PeriodStats(1.0 / rate_hz)
    n, c0 = 0, time.process_time()
    while True:
        now = clock.wait()
        if now > seconds:
            break
        stats.mark(time.monotonic())
        for _ in range(units):
            _work_unit()
        n += 1
    return {"cycles": n, "rate_ratio": n / seconds / rate_hz, "overruns": clock.overruns,
            "rephases": clock.rephases, "period": stats.histogram.summary(),
            "cpu_per_cycle_us": 1e6 * (time.process_time() - c0) / max(n, 1)}


def host_ceiling(seconds: float, rate_hz: float, loop_cpu_per_cycle_s: float) -> dict:
    """The paced loop's schedule without a bus: each cycle does as much pure-Python work as the paced loop
    spent CPU per cycle beyond the bare clock. What this loop loses, the host takes (see the module doc)."""
    freeze_startup_objects()
    bare = _clock_loop(min(1.0, seconds), rate_hz, 0)
    unit = _unit_cpu_s()
    work_s = max(0.0, loop_cpu_per_cycle_s - bare["cpu_per_cycle_us"] * 1e-6)
    units = round(work_s / unit)
    return {"work_cpu_per_cycle_us": 1e6 * units * unit,
            "bare_clock_cpu_per_cycle_us": bare["cpu_per_cycle_us"], **_clock_loop(seconds, rate_hz, units)}


def _with_ceiling(paced: dict, seconds: float, rate_hz: float) -> dict:
    return {**paced, "host_ceiling": host_ceiling(seconds, rate_hz, paced["cpu_per_cycle_us"] * 1e-6)}


def run_paced(seconds: float, rate_hz: float) -> dict:
    """Emulator on a thread of this process (`virtual` bus)."""
    ebus, emu, mb = _rig(lockstep=False)
    stop = threading.Event()
    physics = threading.Thread(target=emu.run, args=(stop,), daemon=True)
    physics.start()
    try:
        paced = _paced_loop(mb, seconds, rate_hz)
    finally:
        stop.set()
        physics.join()
        mb.stop()
        mb.shutdown()
        emu.shutdown()
        ebus.shutdown()
    return {"emulator": "thread", **_with_ceiling(paced, seconds, rate_hz)}


GROUP = "239.74.163.9"


def run_paced_process(seconds: float, rate_hz: float, rt_priority: int | None = None) -> dict:
    """Emulator in its own process on `udp_multicast`; call inside a private network namespace. With
    `rt_priority` both the loop and the emulator run SCHED_FIFO (the emulator stands in for motors, which
    do not share a CPU with the host's other jobs)."""
    for cmd in (["ip", "link", "set", "lo", "up", "multicast", "on"], ["ip", "route", "add", "224.0.0.0/4",
                                                                       "dev", "lo"]):
        subprocess.run(cmd, check=True, capture_output=True)
    chrt = [] if rt_priority is None else ["chrt", "-f", str(rt_priority)]
    emu = subprocess.Popen([*chrt, sys.executable, "-m", "sparc_quad", "motors", "emulate", "--can-interface",
                            "udp_multicast", "--can-channel", GROUP, "--ids", "1,2,3"],
                           stdout=subprocess.PIPE, text=True, cwd=ROOT)
    try:
        if "emulating" not in (emu.stdout.readline() if emu.stdout else ""):
            raise RuntimeError("the emulator process did not start")
        # before the bus: its receive thread inherits the priority (a normal-priority thread holding the
        # GIL would stall the SCHED_FIFO loop whenever the host's other jobs preempt it)
        rt = apply(RtOptions(rt_priority=rt_priority)) if rt_priority is not None else []
        cfg = load_config().with_(silent_timeout_s=1.0, can_timeout_s=1.0)  # tolerate a loaded host
        mb = CanMotorBus(cfg, interface="udp_multicast", channel=GROUP, plausibility=FREE_PLANT)
        mb.start()
        mb.receive(1.0)
        try:
            paced = _paced_loop(mb, seconds, rate_hz)
        finally:
            mb.stop()
            mb.shutdown()
    finally:
        emu.terminate()
        emu.wait(10)
    # after the emulator stopped: the ceiling has this process's CPU to itself, as the loop had
    return {"emulator": "process (udp_multicast, network namespace)", "realtime": rt,
            **_with_ceiling(paced, seconds, rate_hz)}


def _in_netns(argv: list[str]) -> dict:
    """Re-run this script's paced loop inside `unshare -n` (as root) or `unshare -rn`; its JSON result."""
    for prefix in (("unshare", "-n"), ("unshare", "-rn")):
        if shutil.which(prefix[0]) is None:
            break
        r = subprocess.run([*prefix, sys.executable, __file__, *argv, "--inside-netns"], capture_output=True,
                           text=True, cwd=ROOT, env={**os.environ, "PYTHONPATH": str(ROOT)})
        if r.returncode == 0:
            return json.loads(r.stdout.strip().splitlines()[-1])
        err = r.stderr.strip().splitlines()[-1:] or [""]
    raise SystemExit(f"can_loop: cannot run the emulator in its own process here ({err[0] if err else ''}); "
                     "use --emulator thread")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=10.0,
                    help="duration of each loop (default: %(default)s)")
    ap.add_argument("--rate-hz", type=float, default=1000.0)
    ap.add_argument("--emulator", choices=["process", "thread"], default="process",
                    help="paced loop: emulator in its own process (default) or on a thread of this one")
    ap.add_argument("--rt-priority", type=int, default=None,
                    help="run the paced loop and the emulator process SCHED_FIFO at this priority (1..99; "
                         "needs root or CAP_SYS_NICE), as on a torso computer; default: normal scheduling")
    ap.add_argument("--json", type=Path, default=None)
    ap.add_argument("--inside-netns", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if not (math.isfinite(args.seconds) and args.seconds > 0 and math.isfinite(args.rate_hz)
            and args.rate_hz > 0):
        ap.error("--seconds and --rate-hz must be positive numbers")
    logging.basicConfig(level=logging.ERROR)
    if args.inside_netns:
        try:
            print(json.dumps(run_paced_process(args.seconds, args.rate_hz, args.rt_priority)))
        except RtSetupError as exc:
            print(f"can_loop: {exc}", file=sys.stderr)
            return 2
        return 0
    load = bus_load(3, args.rate_hz, 1_000_000, warn=False)
    if args.emulator == "process":
        rt = [] if args.rt_priority is None else ["--rt-priority", str(args.rt_priority)]
        paced = _in_netns(["--seconds", str(args.seconds), "--rate-hz", str(args.rate_hz), *rt])
    else:
        rt = apply(RtOptions(rt_priority=args.rt_priority)) if args.rt_priority is not None else []
        paced = {**run_paced(args.seconds, args.rate_hz), "realtime": rt}
    result = {"motors": 3, "max": {"emulator": "lockstep, in-process virtual bus", **run_max(args.seconds)},
              "paced": paced, "goal_paced_rate_ratio": [0.99, 1.01], "bus_load_model": load.as_dict(),
              "max_rate_hz_for_3_motors_at_80pct": max_loop_rate_hz(3),
              "max_rate_hz_for_n_motors_at_80pct": {n: max_loop_rate_hz(n) for n in range(1, 7)},
              "loadavg": Path("/proc/loadavg").read_text().split()[:3]}
    mx, pc = result["max"], result["paced"]
    print(f"max loop: {mx['rate_hz']:.0f} Hz over CAN frames ({mx['rate_hz'] / args.rate_hz:.2f}x the "
          f"{args.rate_hz:.0f} Hz target); tx {mx['tx_frames_per_s']:.0f} frames/s, rx "
          f"{mx['rx_frames_per_s']:.0f} frames/s")
    print(f"paced loop ({pc['emulator']}): {pc['rate_hz']:.1f} Hz of {args.rate_hz:.0f} Hz "
          f"(ratio {pc['rate_ratio']:.3f}, goal 0.99-1.01); {pc['cycles_without_fresh_feedback']} of "
          f"{pc['cycles']} cycles without fresh feedback, {pc['overruns']} overruns, {pc['rephases']} "
          f"re-phases; period p50/p99/max {pc['period']['p50_us']:.0f}/{pc['period']['p99_us']:.0f}/"
          f"{pc['period']['max_us']:.0f} us; tx {pc['tx_frames_per_s']:.0f}/s, "
          f"rx {pc['rx_frames_per_s']:.0f}/s; CPU {pc['cpu_per_cycle_us']:.0f} us/cycle "
          f"(main thread {pc['main_thread_cpu_per_cycle_us']:.0f})")
    hc = pc["host_ceiling"]
    print(f"host ceiling (same clock, no bus, {hc['work_cpu_per_cycle_us']:.0f} us of Python per cycle): "
          f"ratio {hc['rate_ratio']:.3f}, {hc['overruns']} overruns, {hc['rephases']} re-phases; period max "
          f"{hc['period']['max_us']:.0f} us")
    print(f"bus-load model, 3 motors at {args.rate_hz:.0f} Hz on 1 Mbit/s: {load.frames_per_s:.0f} frames/s, "
          f"{100 * load.utilisation_nominal:.1f} % unstuffed, {100 * load.utilisation_worst:.1f} % "
          f"worst case "
          f"({'over' if load.over_warning else 'under'} the 80 % warning); max rate under 80 %: "
          f"{max_loop_rate_hz(3):.0f} Hz, under 100 %: {max_loop_rate_hz(3, utilisation=1.0):.0f} Hz")
    if args.json:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps(result, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
