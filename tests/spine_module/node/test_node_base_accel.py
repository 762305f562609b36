"""The torso state's base acceleration reaches the node's controller as q̈1 does: when valid as sent, else
none (the fixed-origin law); a non-finite valid one is a rejected torso state (BAD_TORSO), the last good
one staying in force."""

from __future__ import annotations

import numpy as np

from spine_module.messages import Fault, Mode, TorsoState, channels, codec
from tests.node_harness import Harness


def _torso(h: Harness, acc, valid: bool, ddq1: float = 0.0) -> TorsoState:
    return TorsoState(ddq1=ddq1, ddq1_valid=True, base_accel=np.array(acc, dtype=float),
                      base_accel_valid=valid, stamp_s=h.t, seq=h.k)


def test_valid_base_accel_is_passed_invalid_is_zero():
    h = Harness()
    h.send_torso = False
    h.step(600, extra=lambda hh: hh.io.send_torso(_torso(hh, [1.5, 0.0, -2.5], True, 3.0)))
    s = h.states[-1]
    assert s.mode == Mode.IMPEDANCE and s.faults == Fault.NONE
    ddq1, acc = h.ctrl.last_input
    assert ddq1 == 3.0 and acc.tolist() == [1.5, 0.0, -2.5]
    h.step(1, extra=lambda hh: hh.io.send_torso(_torso(hh, [1.5, 0.0, -2.5], False, 3.0)))
    assert h.ctrl.last_input[1] is None


def test_non_finite_valid_base_accel_is_rejected_like_ddq1():
    h = Harness()
    h.send_torso = False
    h.step(600, extra=lambda hh: hh.io.send_torso(_torso(hh, [1.0, 0.0, 0.0], True)))
    raw = codec.decode_raw(channels.TORSO_STATE, codec.encode_torso(_torso(h, [1.0, 0.0, 0.0], True)))
    raw.base_accel = [0.0, float("nan"), 0.0]
    s = h.step(1, extra=lambda hh: hh.io.deliver(channels.TORSO_STATE, raw.encode()))
    assert s.faults & Fault.BAD_TORSO and s.rejected.startswith(f"{channels.TORSO_STATE}.base_accel[1]:")
    assert h.ctrl.last_input[1].tolist() == [1.0, 0.0, 0.0]  # the last good torso state
    raw.base_accel_valid = False  # not valid: whatever it holds is not read
    s = h.step(1, extra=lambda hh: hh.io.deliver(channels.TORSO_STATE, raw.encode()))
    assert h.ctrl.last_input[1] is None


def test_the_node_ticks_on_the_compiled_step_with_and_without_a_base_acceleration(monkeypatch):
    """An input the compiled kernel does not take (a read-only zeros array was one) sends every tick down the
    reference path through numba's failed dispatch: ~150 us a tick instead of ~26 (bench/node_tick.py)."""
    import pytest

    from spine_module.control.impedance import ImpedanceController
    from spine_module.node import Controllers

    ctrls = Controllers.default()
    if ctrls.impedance.backend != "numba":
        pytest.skip("numba is not available here")
    calls = []
    real = ImpedanceController.step_reference
    monkeypatch.setattr(ImpedanceController, "step_reference",
                        lambda self, *a, **k: calls.append(1) or real(self, *a, **k))
    h = Harness(ctrl=ctrls.impedance)  # impedance and PD both the real compiled impedance controller
    h.send_torso = False
    for valid in (False, True):
        h.step(600, extra=lambda hh, v=valid: hh.io.send_torso(_torso(hh, [0.5, 0.0, -1.0], v)))
        assert h.states[-1].mode == Mode.IMPEDANCE and h.states[-1].faults == Fault.NONE
    assert calls == []
