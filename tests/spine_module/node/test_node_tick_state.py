"""What the faster node tick keeps between ticks is safe: states a caller keeps are never changed by a
later tick, the controller's gains and target follow every change (command, soft start, mode, command
stale) although they are set only when something changed, and bus copies share no arrays."""

from __future__ import annotations

import copy

import numpy as np

from spine_module import params as P
from spine_module.buses.base import MotorCommand, MotorFeedback
from spine_module.messages import Fault, Mode, SpineCommand
from spine_module.node import Controllers
from spine_module.safety import Receipts, SafetyState
from tests.node_harness import DT, FakeController, Harness


class CountingController(FakeController):
    def __init__(self) -> None:
        super().__init__()
        self.set_calls = 0
        self.dx_d = self.ddx_d = None

    def set_gains(self, k=None, d=None):
        self.set_calls += 1
        super().set_gains(k, d)

    def set_target(self, x_d=None, dx_d=None, ddx_d=None):
        super().set_target(x_d, dx_d, ddx_d)
        self.dx_d, self.ddx_d = np.array(dx_d, dtype=float), np.array(ddx_d, dtype=float)


def test_kept_states_are_not_changed_by_later_ticks() -> None:
    h = Harness()
    h.node.ctrl = Controllers.default()
    h.step(600)
    kept = h.states[-1]
    snapshot = copy.deepcopy(kept)
    h.dq = np.array([0.3, -0.2, 0.1])
    h.q = h.q + 0.01
    h.step(50)
    assert h.states[-1] is not kept
    for name, v in vars(snapshot).items():
        got = getattr(kept, name)
        if isinstance(v, np.ndarray):
            np.testing.assert_array_equal(got, v, err_msg=name)
            later = getattr(h.states[-1], name)
            assert not np.shares_memory(got, later), name
        else:
            assert got == v, name


def test_gains_and_target_follow_the_command_and_are_set_only_on_change() -> None:
    ctrl = CountingController()
    cmd = SpineCommand(mode=Mode.IMPEDANCE, k=np.array([400.0, 1000.0, 15.0]), d=np.array([4.0, 8.0, 0.2]),
                       dx_d=np.array([0.01, 0.0, 0.0]))
    h = Harness(ctrl=ctrl, command=cmd)
    h.step(int(P.SAFETY.soft_start_s / DT) + 20)
    assert h.states[-1].gain_scale == 1.0
    np.testing.assert_array_equal(ctrl.k, cmd.k)
    calls = ctrl.set_calls
    h.step(100)  # ten more commands, equal numbers in new objects: nothing to set
    assert ctrl.set_calls == calls
    cmd.x_d = cmd.x_d + np.array([0.0, 0.002, 0.0])  # the harness sends it on the next multiple of 10
    h.step(10)
    assert ctrl.set_calls == calls + 1
    np.testing.assert_array_equal(ctrl.x_d, cmd.x_d)
    np.testing.assert_array_equal(ctrl.k, cmd.k)
    cmd.ddx_d = np.array([0.0, 0.0, 1.0])
    h.step(10)
    np.testing.assert_array_equal(ctrl.ddx_d, cmd.ddx_d)
    cmd.d = np.array([5.0, 8.0, 0.2])
    h.step(10)
    np.testing.assert_array_equal(ctrl.d, cmd.d)
    assert ctrl.set_calls == calls + 3


def test_gains_follow_a_mode_switch_and_the_stale_command_fallback() -> None:
    imp, pd = CountingController(), CountingController()
    cmd = SpineCommand(mode=Mode.IMPEDANCE, k=np.array([400.0, 1000.0, 15.0]))
    h = Harness(command=cmd)
    h.node.ctrl = Controllers(impedance=imp, pd=pd)
    h.step(600)
    np.testing.assert_array_equal(imp.k, cmd.k)
    assert pd.k is None
    cmd.mode = Mode.PD
    h.step(600)  # a new ramped mode: soft start again, then full gains on the PD controller
    assert h.states[-1].mode == Mode.PD and h.states[-1].gain_scale == 1.0
    np.testing.assert_array_equal(pd.k, cmd.k)
    h.send_command = False
    h.step(int(P.SAFETY.command_deadline_s / DT) + 20)
    s = h.states[-1]
    assert s.faults & Fault.COMMAND_STALE and s.mode == Mode.IMPEDANCE
    np.testing.assert_array_equal(imp.k, P.K_DEFAULT)
    np.testing.assert_array_equal(imp.dx_d, np.zeros(3))


def test_gains_are_set_again_after_the_controller_raised() -> None:
    ctrl = CountingController()
    h = Harness(ctrl=ctrl)
    h.step(600)
    calls = ctrl.set_calls
    ctrl.raises = True
    h.step()
    ctrl.raises = False
    ctrl.k = None  # as if a failed step left the controller in any state
    h.step()
    assert ctrl.set_calls == calls + 1 and ctrl.k is not None  # not set on the failing tick (unchanged)


def test_safety_and_receipts_are_reported_as_objects() -> None:
    h = Harness()
    h.step(3)
    t = h.t - DT
    assert h.node.rx == Receipts(torso=t, feedback=t, command=0.0, heartbeat=0.0)
    st = h.node.safety
    assert isinstance(st, SafetyState) and st.heartbeat_seen and st.mode == Mode.IMPEDANCE
    assert st.ramp_t0 == 0.0 and st.latched == Fault.NONE and isinstance(st.latched, Fault)


def test_bus_copies_share_no_arrays() -> None:
    cmd = MotorCommand(tau_ff=np.ones(3), kp=np.full(3, 2.0), enable=True, stamp_s=1.5, seq=4)
    fb = MotorFeedback(q=np.ones(3), dq=np.zeros(3), tau=np.zeros(3), stamp_s=2.0, seq=9)
    for orig in (cmd, fb):
        c = orig.copy()
        assert type(c) is type(orig)
        for name, v in vars(orig).items():
            w = getattr(c, name)
            if isinstance(v, np.ndarray):
                np.testing.assert_array_equal(w, v)
                assert not np.shares_memory(v, w), name
            else:
                assert w == v, name
