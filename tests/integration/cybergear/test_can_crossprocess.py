"""Across processes on python-can's `udp_multicast`, inside a private network namespace:

process A: `sparc-quad motors emulate --interface udp_multicast ...` (emulated motors 1, 2, 3);
process B: the CAN backend running a control loop, with stop handlers, killed with SIGTERM;
process C (the orchestrator): python-cybergear scans the bus (independent client), a sniffer records
every frame, `sparc-quad motors status` reads the motors, and the stop frames after SIGTERM are counted.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import textwrap

import pytest

from tests.paths import ROOT

GROUP = "239.74.163.2"

DRIVER = f"""
import numpy as np
from spine_module.buses.base import MotorCommand
from spine_module.buses.cybergear import CanMotorBus, install_stop_handlers
from tests.can_util import rig_config
mb = CanMotorBus(rig_config(), interface="udp_multicast", channel="{GROUP}")
install_stop_handlers(mb)
mb.start()
ticks = 0
try:
    while True:
        if mb.receive(0.5) is not None:
            ticks += 1
        mb.send(MotorCommand(tau_ff=np.full(3, 0.05), kd=np.full(3, 0.2)))
        if ticks == 200:
            print("READY", flush=True)
finally:
    mb.shutdown()
"""

ORCHESTRATOR = textwrap.dedent(f"""
    import json, os, signal, subprocess, sys, time
    import can
    subprocess.run(["ip", "link", "set", "lo", "up", "multicast", "on"], check=True)
    subprocess.run(["ip", "route", "add", "224.0.0.0/4", "dev", "lo"], check=True)
    from tests.can_util import Sniffer, wait_for
    from spine_module.buses.cybergear import protocol as P

    py, chan = sys.executable, "{GROUP}"
    out = {{}}
    emu = subprocess.Popen([py, "-m", "sparc_quad", "motors", "emulate", "--can-interface", "udp_multicast",
                            "--can-channel", chan, "--ids", "1,2,3"], stdout=subprocess.PIPE, text=True)
    assert "emulating" in emu.stdout.readline()
    sbus = can.Bus(interface="udp_multicast", channel=chan)
    sniffer = Sniffer()
    notifier = can.Notifier(sbus, [sniffer], timeout=0.05)
    import cybergear
    found = cybergear.CyberGearMotor.scan(bus_config={{"interface": "udp_multicast", "channel": chan}},
                                          timeout=0.5, candidates=[1, 2, 3, 4])
    out["scan"] = [cid for cid, _ in found]
    st = subprocess.run([py, "-m", "sparc_quad", "motors", "status", "--can-interface", "udp_multicast",
                         "--can-channel", chan], capture_output=True, text=True, timeout=60)
    out["status_rc"], out["status"] = st.returncode, st.stdout
    driver = subprocess.Popen([py, sys.argv[1]], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    line = driver.stdout.readline()
    out["driver_ready"] = line.strip()
    if line.strip() != "READY":
        out["driver_err"] = driver.stderr.read()[-2000:]
    n0 = len(sniffer.frames)
    driver.send_signal(signal.SIGTERM)
    driver.wait(timeout=60)
    out["driver_rc"] = driver.returncode
    # the stop frames are on the wire once the driver has exited; wait until the sniffer has them all
    wait_for(lambda: all(any(P.split_id(m.arbitration_id)[0] == 4 and (m.arbitration_id & 0xFF) == i
                             for m in sniffer.frames[n0:]) for i in (1, 2, 3)), timeout_s=30)
    after = sniffer.frames[n0:]
    out["stops_after"] = {{i: sum(1 for m in after if P.split_id(m.arbitration_id)[0] == 4
                                  and (m.arbitration_id & 0xFF) == i) for i in (1, 2, 3)}}
    modes = {{}}
    for m in after:
        if P.split_id(m.arbitration_id)[0] == 2:
            f = P.decode_from_motor(m)
            modes[f.motor_id] = f.mode
    out["last_modes"] = modes
    out["control_frames"] = sum(1 for m in sniffer.frames if P.split_id(m.arbitration_id)[0] == 1)
    emu.send_signal(signal.SIGTERM)
    rest = emu.communicate(timeout=60)[0]
    out["emu_rc"], out["emu_out"] = emu.returncode, rest
    notifier.stop()
    sbus.shutdown()
    print(json.dumps(out))
""")


@pytest.mark.netns
def test_cross_process_udp_multicast(tmp_path):
    if shutil.which("unshare") is None or shutil.which("ip") is None:
        pytest.skip("needs unshare and ip")
    probe = subprocess.run(["unshare", "-rn", "true"], capture_output=True)
    if probe.returncode != 0:
        pytest.skip(f"cannot make a network namespace: {probe.stderr.decode().strip()}")
    script = tmp_path / "orchestrate.py"
    script.write_text(ORCHESTRATOR)
    driver = tmp_path / "driver.py"
    driver.write_text(DRIVER)
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    proc = subprocess.run(["unshare", "-rn", sys.executable, str(script), str(driver)], cwd=ROOT,
                          env=env, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr[-3000:]
    out = json.loads(proc.stdout.strip().splitlines()[-1])
    # the independent client sees the emulator in the other process; udp_multicast also hands the client
    # its own get-id requests back, which python-cybergear's scan counts as "motor" 0xFD (its host id)
    assert set(out["scan"]) - {0xFD} == {1, 2, 3}
    assert out["status_rc"] == 0 and out["status"].count("VBUS=24") == 3
    assert out["driver_ready"] == "READY", out.get("driver_err")
    assert out["control_frames"] >= 600
    assert out["driver_rc"] == 143
    assert all(n >= 1 for n in out["stops_after"].values()), out["stops_after"]
    assert out["last_modes"] == {"1": 0, "2": 0, "3": 0}  # every motor answered its stop in RESET
    assert out["emu_rc"] == 0 and "0 frames rejected" in out["emu_out"]
