"""Across processes on python-can's `udp_multicast` in a private network namespace,
in real time, as a user would run them:

1. the no-hardware recipe of docs/cybergear.md (`motors emulate` + `spine-node --motors can`) ends with
   no latched motor fault (it latched "left run mode" in 4 of 4 runs before the stop-frame race was fixed);
2. SIGKILL of `spine-node --motors can` while it drives the emulated motors, "the robot" publishing torso
   state and torque commands before the node starts: with the shipped motors.toml (CAN timeout 0.05 s) the
   node drives without a trip or a latched fault from enable on, and after the kill every motor is at zero
   torque within its timeout, in the emulator's clock;
3. the same kill with the CAN timeout off (`can_timeout_s = 0`, `can_timeout_off = true`): the motors keep
   running (the hazard);
4. ... and with `sparc-quad motors watchdog` running, the watchdog stops them.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap

import pytest

from tests.node_netns import unshare_prefix
from tests.paths import ROOT

SCRIPT = textwrap.dedent("""
    import json, os, signal, subprocess, sys, threading, time
    import can, lcm
    import numpy as np
    subprocess.run(["ip", "link", "set", "lo", "up", "multicast", "on"], check=True)
    subprocess.run(["ip", "route", "add", "224.0.0.0/4", "dev", "lo"], check=True)
    from tests.can_util import Sniffer
    from spine_module.buses.cybergear import protocol as P
    from spine_module.messages import Mode, SpineCommand, TorsoState, channels, codec

    py, chan, tmp, phases = sys.executable, "239.74.163.2", sys.argv[1], sys.argv[2].split(",")
    cli = [py, "-m", "sparc_quad"]
    can_opts = ["--can-interface", "udp_multicast", "--can-channel", chan]
    res = {}

    def emulator():
        p = subprocess.Popen([*cli, "motors", "emulate", *can_opts,
                              "--ids", "1,2,3"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        assert "emulating" in p.stdout.readline()
        return p

    def end_emulator(p):
        p.send_signal(signal.SIGTERM)
        out, err = p.communicate(timeout=60)
        lines = [l for l in out.splitlines() if l.startswith("{")]
        return json.loads(lines[-1]) if lines else {"error": out[-800:] + err[-800:]}

    sbus = can.Bus(interface="udp_multicast", channel=chan)
    sn = Sniffer()
    nt = can.Notifier(sbus, [sn], timeout=0.05)

    if "recipe" in phases:  # docs/cybergear.md's recipe as written (default LCM URL and motor config)
        emu = emulator()
        node = subprocess.run([*cli, "spine-node", "--motors", "can", *can_opts, "--duration", "3"],
                              capture_output=True, text=True, timeout=180)
        out = node.stdout.strip()
        res["recipe"] = {"rc": node.returncode, "err": node.stderr[-1500:],
                         "summary": json.loads(out.splitlines()[-1]) if out else None}
        end_emulator(emu)

    # torso state and a joint-torque command for the node, from "the robot" (this process)
    lc = lcm.LCM()
    feeding = threading.Event()

    def feed():
        k = 0
        while not feeding.is_set():
            k += 1
            t = time.monotonic()
            lc.publish(channels.TORSO_STATE, codec.encode_torso(TorsoState(stamp_s=t, seq=k)))
            lc.publish(channels.SPINE_COMMAND, codec.encode_command(SpineCommand(
                mode=Mode.JOINT_TORQUE, tau_ff=np.array([0.2, -0.2, 0.2]), stamp_s=t, seq=k)))
            time.sleep(0.002)

    def kill_run(name, config=None, watchdog=False):
        sn.clear()
        emu = emulator()
        dog = None
        if watchdog:
            dog = subprocess.Popen([*cli, "motors", "watchdog", *can_opts, "--deadline", "0.05"],
                                   stdout=subprocess.PIPE,
                                   stderr=subprocess.PIPE, text=True)
            assert "watchdog" in dog.stdout.readline()
        extra = ["--motor-config", config] if config else []
        node = subprocess.Popen([*cli, "spine-node", "--motors", "can", *can_opts, "--no-heartbeat", *extra],
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        deadline = time.monotonic() + 90
        def driving():  # type-1 frames with a torque of about +-0.2 N*m (id bits 23..8)
            return [m for m in sn.of_type(P.CommType.OPERATION_CONTROL)
                    if abs(P.u16_to_float((m.arbitration_id >> 8) & 0xFFFF, -12.0, 12.0)) > 0.1]
        while time.monotonic() < deadline and len(driving()) < 100 and node.poll() is None:
            time.sleep(0.05)
        with sn._lock:
            frames = list(sn.frames)
        enables = [m.timestamp for m in frames if P.split_id(m.arbitration_id)[0] == P.CommType.ENABLE]
        commands = [m.timestamp for m in frames if P.split_id(m.arbitration_id)[0] == 1
                    and enables and m.timestamp > enables[0]]
        r = {"driving_frames": len(driving()),
             "enable_to_first_type1_s": commands[0] - enables[-1] if commands and enables else None}
        n0 = len(sn.frames)
        node.send_signal(signal.SIGKILL)
        node.wait(timeout=30)
        time.sleep(0.6)
        after = sn.frames[n0:]
        r["stops_after"] = {i: sum(1 for m in after if P.split_id(m.arbitration_id)[0] == 4
                                   and m.arbitration_id & 0xFF == i) for i in (1, 2, 3)}
        r["emu"] = end_emulator(emu)
        if dog is not None:
            dog.send_signal(signal.SIGTERM)
            out, err = dog.communicate(timeout=30)
            lines = [l for l in out.splitlines() if l.startswith("{")]
            r["watchdog"] = json.loads(lines[-1])["watchdog_fired"] if lines else err[-800:]
        r["node_err"] = node.stderr.read()[-1500:]
        res[name] = r

    th = threading.Thread(target=feed, daemon=True)
    th.start()
    from spine_module.buses.cybergear.config import DEFAULT_CONFIG_PATH

    def config(timeout_s):  # the packaged file with another CAN timeout
        path = os.path.join(tmp, f"motors_{timeout_s}.toml")
        off = "\\ncan_timeout_off = true" if timeout_s == 0 else ""
        open(path, "w").write(DEFAULT_CONFIG_PATH.read_text().replace("can_timeout_s = 0.05",
                                                                      f"can_timeout_s = {timeout_s}{off}"))
        return path
    if "can_timeout" in phases:
        kill_run("can_timeout")  # the shipped motors.toml
    if "no_timeout" in phases:
        kill_run("no_timeout", config(0.0))
    if "watchdog" in phases:
        kill_run("watchdog", config(0.0), watchdog=True)
    feeding.set()
    nt.stop()
    sbus.shutdown()
    print(json.dumps(res))
""")


TIMEOUT_S = 0.05  # the shipped motors.toml's can_timeout_s


def _run(tmp_path, phases: str) -> dict:
    if unshare_prefix() is None:
        pytest.skip("cannot make a network namespace")
    script = tmp_path / "kill.py"
    script.write_text(SCRIPT)
    proc = subprocess.run([*unshare_prefix(), sys.executable, str(script), str(tmp_path), phases], cwd=ROOT,
                          env=dict(os.environ, PYTHONPATH=str(ROOT)), capture_output=True, text=True,
                          timeout=560)
    assert proc.returncode == 0, proc.stderr[-3000:]
    return json.loads(proc.stdout.strip().splitlines()[-1])


def _killed_while_driving(r: dict) -> None:
    assert r["driving_frames"] >= 100, r["node_err"]
    assert all(n == 0 for n in r["stops_after"].values()), r  # SIGKILL: the node sent no stop


@pytest.mark.netns
def test_readme_recipe_and_sigkill_stops_motors_within_their_can_timeout(tmp_path):
    res = _run(tmp_path, "recipe,can_timeout")
    recipe = res["recipe"]
    assert recipe["rc"] == 0, recipe["err"]
    assert recipe["summary"]["ticks"] > 0 and recipe["summary"]["bus_faults"] == [], recipe
    assert "left run mode" not in recipe["err"]

    from spine_module.buses.cybergear import load_config

    assert load_config().can_timeout_s == TIMEOUT_S
    r = res["can_timeout"]
    _killed_while_driving(r)
    assert "left run mode" not in r["node_err"] and "motor bus error" not in r["node_err"], r["node_err"]
    trips = {t["motor"]: t for t in r["emu"]["can_timeout_trips"]}
    assert set(trips) == {1, 2, 3} and len(r["emu"]["can_timeout_trips"]) == 3, r  # one trip: the kill's
    for t in trips.values():
        assert t["can_timeout_s"] == TIMEOUT_S
        assert t["tripped_s"] - t["last_frame_s"] >= TIMEOUT_S
        # torque was still applied after the last frame, and no plant step after the timeout had torque
        assert 0 < t["last_torque_s"] - t["last_frame_s"] < TIMEOUT_S
    print("enable -> first type-1 frame (s):", r["enable_to_first_type1_s"],
          "CAN timeout: trip latency after the last frame (ms):",
          {i: round((t["tripped_s"] - t["last_frame_s"]) * 1e3, 2) for i, t in trips.items()},
          "last torque (ms):", {i: round((t["last_torque_s"] - t["last_frame_s"]) * 1e3, 2)
                                for i, t in trips.items()})


@pytest.mark.netns
@pytest.mark.slow
def test_sigkill_without_can_timeout_keeps_motors_running_unless_the_watchdog_runs(tmp_path):
    res = _run(tmp_path, "no_timeout,watchdog")
    r = res["no_timeout"]  # the hazard: with no CAN timeout nothing stops the motors
    _killed_while_driving(r)
    emu = r["emu"]
    assert emu["can_timeout_trips"] == []
    for m in emu["motors"].values():
        assert m["mode"] == 2 and m["last_torque_s"] - m["last_frame_s"] > 0.5  # still RUN, still pushing
    r = res["watchdog"]
    assert r["driving_frames"] >= 100, r["node_err"]
    assert all(n >= 1 for n in r["stops_after"].values()), r  # from the watchdog
    assert r["emu"]["can_timeout_trips"] == [] and all(m["mode"] == 0 for m in r["emu"]["motors"].values())
    (fire,) = r["watchdog"]
    latency = fire["fired_s"] - fire["last_host_frame_s"]
    assert latency > 0.05
    print(f"watchdog: stop frames {latency * 1e3:.1f} ms after the node's last frame")
