"""The spine node with `--motors can`: node -> CanMotorBus -> CAN frames -> emulated CyberGears -> pybullet.

The static push-pull meets the same 1.5 % stiffness criterion as in-process, and agrees with the in-process
node run; motor faults on the bus become node faults, put the node in a safe mode, and end in stop frames.
"""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("spine_module.node")

from sparc_quad.sim.bench_robot import run_inprocess, static_push_script, stiffness_from_states
from sparc_quad.sim.cybergear_bench import node_stiffness, run_node_over_can
from spine_module import params as P
from spine_module.messages import Fault, Mode


def test_node_static_stiffness_over_can():
    k = 500.0
    run = run_node_over_can(static_push_script(k, cycles=1.0))
    assert run.emulator_rejected == 0 and run.bus_stats["send_errors"] == 0
    assert all(s.mode == Mode.IMPEDANCE for s in run.states[100:])
    k_hat, r2, n = node_stiffness(run, P.X_EQUILIBRIUM[0], skip_s=1.0)
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
