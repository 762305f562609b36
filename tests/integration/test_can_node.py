"""The spine node with `--motors can`: node -> CanMotorBus -> CAN frames -> emulated CyberGears -> pybullet.

The static push-pull meets the same 1.5 % stiffness criterion as in-process, and agrees with the in-process
node run; motor faults on the bus become node faults, put the node in a safe mode, and end in stop frames.
"""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("spine_module.node")

from sparc_quad.experiments.scripts import static_push_script
from sparc_quad.experiments.stats import stiffness_fit, stiffness_from_states
from sparc_quad.robot_side.bench import run_inprocess
from sparc_quad.robot_side.can import run_node_over_can
from spine_module import params as P
from spine_module.buses.cybergear import load_config
from spine_module.messages import Fault, Mode
from tests.paths import ROOT


@pytest.mark.parametrize("torque_mode", ["operation", "current"])
def test_node_static_stiffness_over_can(torque_mode):
    k = 500.0
    cfg = load_config().with_(torque_mode=torque_mode)
    run = run_node_over_can(static_push_script(k, cycles=1.0), config=cfg)
    assert run.emulator_rejected == 0 and run.bus_stats["send_errors"] == 0
    assert all(s.mode == Mode.IMPEDANCE for s in run.states[100:])
    fit = stiffness_fit(run.states_arrays(), P.X_EQUILIBRIUM[0], skip_s=1.0)
    k_hat, r2, n = fit.slope, fit.r2, fit.n
    assert n >= 6000 and r2 > 0.99
    assert abs(k_hat - k) / k < 0.015, k_hat
    _, states = run_inprocess(static_push_script(k, cycles=1.0))
    assert abs(k_hat - stiffness_from_states(states, skip_s=1.0)) / k < 0.005
    assert run.stop_frames_sent >= 3  # node.stop() at the end


@pytest.mark.parametrize("name,inject", [
    ("silent motor", lambda emu: emu.set_silent(2)),
    ("fault frame", lambda emu: emu.inject_fault(3, fault_value=1)),
    ("malformed frame", lambda emu: emu.send_malformed(1)),
])
def test_node_motor_faults_over_can(name, inject):
    k0 = 300

    def on_tick(k, emu):
        if k == k0:
            inject(emu)
    run = run_node_over_can(static_push_script(500.0, cycles=1.0), n_ticks=600, on_tick=on_tick)
    before, after = run.states[k0 - 50:k0], run.states[k0 + 20:]
    assert all(s.mode == Mode.IMPEDANCE and not s.faults & Fault.BUS for s in before)
    assert all(s.faults & Fault.BUS for s in after), name  # the bus reports it every tick
    assert all(s.mode == Mode.DISABLED for s in after), name  # feedback stale: zero torque
    assert all(np.all(s.tau_cmd == 0.0) for s in after)
    assert run.stop_frames_sent >= 3  # node.stop() at the end; latched faults also stop every tick


# Every wait below is on an event (a line, a frame count, a process exit) with a generous deadline, never
# a guessed duration: the node has control frames to send only once a torque-producing mode is asked for,
# so the script asks for DAMPING over LCM (torso state absent: the node damps) until it has seen them.
NODE_CLI = """
import json, signal, subprocess, sys, time, can, lcm
subprocess.run(["ip", "link", "set", "lo", "up", "multicast", "on"], check=True)
subprocess.run(["ip", "route", "add", "224.0.0.0/4", "dev", "lo"], check=True)
from tests.can_util import Sniffer, wait_for
from spine_module.buses.cybergear import protocol as P
from spine_module.messages import Mode, SpineCommand, channels, codec
py, chan, log = sys.executable, "239.74.163.2", sys.argv[1]
import pathlib
mcfg = pathlib.Path(log).with_name("motors.toml")  # the shipped file (CAN timeout 0.05 s), passed explicitly
from spine_module.buses.cybergear import config as cfgmod
mcfg.write_text(pathlib.Path(cfgmod.__file__).with_name("motors.toml").read_text())
node_err = pathlib.Path(log).with_name("node_err.txt")
def die_with_parent():  # a timeout that kills this script must not leave the node or emulator behind
    import ctypes
    ctypes.CDLL("libc.so.6", use_errno=True).prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG
emu = subprocess.Popen([py, "-m", "sparc_quad", "motors", "emulate", "--can-interface", "udp_multicast",
                        "--can-channel", chan, "--ids", "1,2,3"], stdout=subprocess.PIPE, text=True,
                       preexec_fn=die_with_parent)
emu.stdout.readline()
sbus = can.Bus(interface="udp_multicast", channel=chan)
sn = Sniffer()
nt = can.Notifier(sbus, [sn], timeout=0.05)
node = subprocess.Popen([py, "-m", "sparc_quad", "spine-node", "--motors", "can", "--can-interface",
                         "udp_multicast", "--can-channel", chan, "--lcm-url", channels.DEFAULT_URL,
                         "--no-heartbeat", "--can-log", log, "--motor-config", str(mcfg)],
                        stdout=subprocess.PIPE, stderr=open(node_err, "w"), text=True,
                        preexec_fn=die_with_parent)  # stderr to a file: a full stderr pipe blocks the node
lc = lcm.LCM(channels.DEFAULT_URL)
damp = codec.encode_command(SpineCommand(mode=Mode.DAMPING))
def control_frames_or_exit():
    lc.publish(channels.SPINE_COMMAND, damp)  # UDP: keep asking until the node acts on it
    return len(sn.of_type(P.CommType.OPERATION_CONTROL)) >= 300 or node.poll() is not None
controlled = wait_for(control_frames_or_exit, timeout_s=240)
n0 = len(sn.frames)
node.send_signal(signal.SIGTERM)
out, err = node.communicate(timeout=120)
wait_for(lambda: all(any(P.split_id(m.arbitration_id)[0] == 4 and m.arbitration_id & 0xFF == i
                         for m in sn.frames[n0:]) for i in (1, 2, 3)), timeout_s=30)
res = {"rc": node.returncode, "controlled": controlled,
       "summary": out.strip().splitlines()[-1] if out.strip() else "",
       "err": node_err.read_text()[-1500:],
       "types": sorted({P.split_id(m.arbitration_id)[0] for m in sn.frames[:n0]}),
       "stops_after": {i: sum(1 for m in sn.frames[n0:] if P.split_id(m.arbitration_id)[0] == 4
                              and m.arbitration_id & 0xFF == i) for i in (1, 2, 3)}}
emu.send_signal(signal.SIGTERM)
emu.communicate(timeout=30)
nt.stop()
sbus.shutdown()
print(json.dumps(res))
"""


@pytest.mark.netns
def test_spine_node_motors_can_cli_sigterm(tmp_path):
    """`sparc-quad spine-node --motors can` across processes on udp_multicast: handshake, control frames,
    SIGTERM ends in stop frames to every motor; the session log is written."""
    import json
    import os
    import shutil
    import subprocess
    import sys

    import can

    if shutil.which("unshare") is None or subprocess.run(["unshare", "-rn", "true"]).returncode != 0:
        pytest.skip("cannot make a network namespace")
    root = ROOT
    script, log = tmp_path / "node_cli.py", tmp_path / "session.blf"
    script.write_text(NODE_CLI)
    proc = subprocess.run(["unshare", "-rn", sys.executable, str(script), str(log)], cwd=root,
                          env=dict(os.environ, PYTHONPATH=str(root)), capture_output=True, text=True,
                          timeout=540)  # under pytest's 600 s; the script's own waits are on events
    assert proc.returncode == 0, proc.stderr[-3000:]
    res = json.loads(proc.stdout.strip().splitlines()[-1])
    assert res["rc"] == 0, res["err"]
    assert res["controlled"], res
    assert {0, 1, 2, 3, 4, 18} <= set(res["types"])  # get id, control, feedback, enable, stop, run_mode
    assert all(n >= 1 for n in res["stops_after"].values()), res
    assert json.loads(res["summary"])["ticks"] > 0
    assert sum(1 for _ in can.LogReader(str(log))) > 300


class _GlitchingReadout:
    """The emulator's load with one motor's readout off by (dq_rad, dv_rad_s) while `active`: the motor's own
    feedback frames carry the bad encoder or velocity reading (its torque law and the physics do not)."""

    def __init__(self, inner, motor_id: int, dq_rad: float, dv_rad_s: float) -> None:
        self.inner, self.motor_id, self.dq_rad, self.dv_rad_s = inner, motor_id, dq_rad, dv_rad_s
        self.active = False

    def read(self, motor_id: int) -> tuple[float, float]:
        q, v = self.inner.read(motor_id)
        if self.active and motor_id == self.motor_id:
            return q + self.dq_rad, v + self.dv_rad_s
        return q, v

    def step(self, torques: dict[int, float], dt: float) -> None:
        self.inner.step(torques, dt)


@pytest.mark.parametrize("name,motor,dq,dv", [
    ("+2 rad encoder glitch on q2", 1, 2.0, 0.0),
    ("0.5 rad encoder glitch on q3, inside its range", 2, 0.5, 0.0),
    ("29 rad/s velocity spike on q3", 2, 0.0, 29.0),
])
def test_node_never_drives_on_an_implausible_frame(name, motor, dq, dv):
    """Issue 31: one bad feedback reading (for 50 ms) gave up to +-12 N*m with no fault. Now the backend
    latches it: from the first bad frame on the node sends zero torque and reports BUS."""
    k0 = 300
    glitch: list[_GlitchingReadout] = []

    def on_tick(k, emu):
        with emu.lock:
            if not glitch:
                glitch.append(_GlitchingReadout(emu.load, motor, dq, dv))
                emu.load = glitch[0]
            glitch[0].active = k0 <= k < k0 + 50  # in the reply to command k: tick k + 1 reads it
    run = run_node_over_can(static_push_script(500.0, cycles=1.0), n_ticks=450, on_tick=on_tick)
    # the emulator answers command k0 - 1 in its own thread, before or after on_tick(k0): the first bad
    # frame reaches tick k0 or k0 + 1
    before, around = run.states[k0 - 50:k0], run.states[k0:]
    assert all(s.mode == Mode.IMPEDANCE and not s.faults & Fault.BUS for s in before)
    first = next(i for i, s in enumerate(around) if s.faults & Fault.BUS)
    assert first <= 2, first
    for s in around[:first]:  # ticks before the latch ran on good feedback
        assert abs(s.dq[motor]) < 5.0 and abs(s.q[motor] - before[-1].q[motor]) < 0.05, name
    after = around[first:]
    peak = max(float(np.max(np.abs(s.tau_cmd))) for s in after)
    assert peak == 0.0, f"{name}: {peak} N*m after the glitch"
    assert all(s.faults & Fault.BUS for s in after), name
