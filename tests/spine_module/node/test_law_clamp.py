"""Issue 31: TORQUE_CLAMPED whenever any clamp cuts a torque, the controller's own included.

The impedance law clamps its output at the torque limit itself (`ControlOutput.saturated`), so the node's
output stage never saw a torque beyond it: a loop pinned at +-12 N*m showed `faults` NONE. Here the real
controller is asked for a target far from the pose with stiff gains: its own clamp cuts, and the node's
state must say so on every such tick.
"""

from __future__ import annotations

import numpy as np

from spine_module import params as P
from spine_module.messages import Fault, Mode, SpineCommand
from spine_module.node import Controllers
from spine_module.safety import SafetyConfig
from tests.node_harness import Harness


def test_the_laws_own_clamp_raises_torque_clamped():
    cmd = SpineCommand(mode=Mode.IMPEDANCE, x_d=np.array([0.25, 0.05, 0.2]),
                       k=np.array([5000.0, 10000.0, 150.0]),
                       d=np.array([20.0, 20.0, 0.3]))
    h = Harness(safety=SafetyConfig(soft_start_s=0.0, soft_start_target=False), command=cmd)
    real = Controllers.default()
    h.node.ctrl = real
    h.step(30)
    at_limit = [s for s in h.states if s.mode == Mode.IMPEDANCE
                and np.max(np.abs(s.tau_cmd)) >= P.TORQUE_LIMIT_NM - 1e-9]
    assert at_limit, "the law never reached its clamp: the test does not test anything"
    assert all(s.faults & Fault.TORQUE_CLAMPED for s in at_limit)
