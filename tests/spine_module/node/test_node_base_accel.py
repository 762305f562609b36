"""The torso state's base acceleration reaches the node's controller as q̈1 does: when valid as sent, else
zeros (the fixed-origin law); a non-finite valid one is a rejected torso state (BAD_TORSO), the last good
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
    assert h.ctrl.last_input[1].tolist() == [0.0, 0.0, 0.0]


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
    assert h.ctrl.last_input[1].tolist() == [0.0, 0.0, 0.0]
