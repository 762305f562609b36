"""Control loop over CAN with 3 emulated CyberGears: achieved rate, frames per second each way, bus load.

Two loops in one run, both on python-can's `virtual` bus in this process (emulator on its own bus object
and notifier thread, the backend on another):
- "max": the emulator in lockstep (one plant step per full command set), the loop runs as fast as the
  host allows: receive feedback of 3 motors, send 3 operation-control frames;
- "paced": the loop paced at --rate-hz on the monotonic clock, emulator free-running: how close the
  host gets to the target rate and how many cycles lacked fresh feedback.
It also prints the bus-load model (8-byte extended frames, worst-case stuffing) for 3 motors at --rate-hz
on a 1 Mbit/s bus, and the highest rate that keeps it under 80 %.

usage: python bench/can_loop.py [--seconds 2] [--rate-hz 1000] [--json PATH]
"""

from __future__ import annotations

import argparse
import json
import logging
import sys
import threading
import time
import uuid
from pathlib import Path

import can
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from sparc_quad.sim.cybergear_emulator import CyberGearEmulator
from spine_module.buses.base import MotorCommand
from spine_module.buses.cybergear import CanMotorBus, bus_load, load_config, max_loop_rate_hz


def _rig(lockstep: bool):
    channel = f"bench-{uuid.uuid4().hex[:8]}"
    ebus = can.Bus(interface="virtual", channel=channel)
    emu = CyberGearEmulator(ebus, (1, 2, 3), lockstep=lockstep)
    emu.keep_log = False
    cfg = load_config().with_(silent_timeout_s=1.0)
    mb = CanMotorBus(cfg, interface="virtual", channel=channel)
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


def run_paced(seconds: float, rate_hz: float) -> dict:
    ebus, emu, mb = _rig(lockstep=False)
    stop = threading.Event()
    physics = threading.Thread(target=emu.run, args=(stop,), daemon=True)
    physics.start()
    cmd = MotorCommand(tau_ff=np.full(3, 0.1), kd=np.full(3, 0.05))
    period = 1.0 / rate_hz
    tx0, rx0 = mb.tx_frames, mb.rx_frames
    n, stale, late = 0, 0, 0
    t0 = time.perf_counter()
    t_next = t0
    try:
        while time.perf_counter() - t0 < seconds:
            fb = None
            while True:
                got = mb.receive(0.0)
                if got is None:
                    break
                fb = got
            stale += fb is None
            mb.send(cmd)
            n += 1
            t_next += period
            delay = t_next - time.perf_counter()
            if delay > 0:
                time.sleep(delay)
            else:
                late += 1
                t_next = time.perf_counter()
        dt = time.perf_counter() - t0
        return {"cycles": n, "seconds": dt, "rate_hz": n / dt, "target_hz": rate_hz,
                "rate_ratio": n / dt / rate_hz, "cycles_without_fresh_feedback": stale, "late_cycles": late,
                "tx_frames_per_s": (mb.tx_frames - tx0) / dt, "rx_frames_per_s": (mb.rx_frames - rx0) / dt}
    finally:
        stop.set()
        physics.join()
        mb.stop()
        mb.shutdown()
        emu.shutdown()
        ebus.shutdown()


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=2.0, help="duration of each loop")
    ap.add_argument("--rate-hz", type=float, default=1000.0)
    ap.add_argument("--json", type=Path, default=None)
    args = ap.parse_args(argv)
    logging.basicConfig(level=logging.ERROR)
    load = bus_load(3, args.rate_hz, 1_000_000, warn=False)
    result = {"motors": 3, "interface": "virtual (in-process)", "max": run_max(args.seconds),
              "paced": run_paced(args.seconds, args.rate_hz), "bus_load_model": load.as_dict(),
              "max_rate_hz_for_n_motors_at_80pct": {n: max_loop_rate_hz(n) for n in range(1, 7)}}
    mx, pc = result["max"], result["paced"]
    print(f"max loop: {mx['rate_hz']:.0f} Hz over CAN frames ({mx['rate_hz'] / args.rate_hz:.2f}x the "
          f"{args.rate_hz:.0f} Hz target); tx {mx['tx_frames_per_s']:.0f} frames/s, rx "
          f"{mx['rx_frames_per_s']:.0f} frames/s")
    print(f"paced loop: {pc['rate_hz']:.0f} Hz of {args.rate_hz:.0f} Hz ({pc['rate_ratio']:.3f}); "
          f"{pc['cycles_without_fresh_feedback']} of {pc['cycles']} cycles without fresh feedback, "
          f"{pc['late_cycles']} late; tx {pc['tx_frames_per_s']:.0f}/s, rx {pc['rx_frames_per_s']:.0f}/s")
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
