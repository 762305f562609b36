"""The safety functions alone: pure functions of state and time."""

from __future__ import annotations

import numpy as np

from spine_module import params as P
from spine_module.messages import Fault, Mode
from spine_module.safety import (
    Receipts,
    SafetyConfig,
    SafetyState,
    clamp_torque,
    damping_torque,
    joint_limit_damping,
    supervise,
)

CFG = SafetyConfig()
FRESH = Receipts(torso=1.0, feedback=1.0, command=1.0, heartbeat=1.0)


def test_all_fresh_runs_the_requested_mode():
    s, v = supervise(SafetyState(), 1.0, FRESH, Mode.IMPEDANCE, False, CFG)
    assert v.mode == Mode.IMPEDANCE and v.faults == Fault.NONE and v.enable and v.gain_scale == 0.0
    s, v = supervise(s, 1.25, Receipts(1.25, 1.25, 1.25, 1.25), Mode.IMPEDANCE, False, CFG)
    assert v.gain_scale == 0.5  # soft start: 0.25 s into a 0.5 s ramp
    s, v = supervise(s, 2.0, Receipts(2.0, 2.0, 2.0, 2.0), Mode.IMPEDANCE, False, CFG)
    assert v.gain_scale == 1.0


def test_is_pure():
    s0 = SafetyState()
    a = supervise(s0, 1.0, FRESH, Mode.ESTOP, False, CFG)
    b = supervise(s0, 1.0, FRESH, Mode.ESTOP, False, CFG)
    assert a == b and s0 == SafetyState()


def test_waiting_until_first_feedback_and_heartbeat():
    _, v = supervise(SafetyState(), 0.0, Receipts(torso=0.0, command=0.0), Mode.IMPEDANCE, False, CFG)
    assert v.faults & Fault.WAITING and not v.enable and v.mode == Mode.DISABLED


def test_deadlines_are_strictly_after():
    d = CFG.torso_deadline_s
    _, v = supervise(SafetyState(), 1.0 + d, FRESH, Mode.IMPEDANCE, False, CFG)
    assert not v.faults & Fault.TORSO_STALE
    _, v = supervise(SafetyState(), 1.0 + d + 1e-6, Receipts(torso=1.0, feedback=1.0 + d, command=1.0,
                                                             heartbeat=1.0 + d), Mode.IMPEDANCE, False, CFG)
    assert v.faults & Fault.TORSO_STALE and v.mode == Mode.DAMPING


def test_feedback_stale_beats_torso_stale():
    _, v = supervise(SafetyState(), 1.1, Receipts(torso=1.0, feedback=1.0, command=1.1, heartbeat=1.1),
                     Mode.IMPEDANCE, False, CFG)
    assert v.mode == Mode.DISABLED and v.faults & Fault.FEEDBACK_STALE and v.faults & Fault.TORSO_STALE


def test_heartbeat_latch_needs_fresh_heartbeat_and_reset():
    s, v = supervise(SafetyState(), 1.2, Receipts(1.2, 1.2, 1.2, 1.0), Mode.IMPEDANCE, False, CFG)
    assert s.latched & Fault.HEARTBEAT_LOST and not v.enable
    s, v = supervise(s, 1.3, Receipts(1.3, 1.3, 1.3, 1.3), Mode.IMPEDANCE, False, CFG)
    assert s.latched & Fault.HEARTBEAT_LOST  # fresh again, still latched
    s, v = supervise(s, 1.31, Receipts(1.31, 1.31, 1.31, 1.0), Mode.IMPEDANCE, True, CFG)
    assert s.latched & Fault.HEARTBEAT_LOST  # reset while the heartbeat is still lost: refused
    s, v = supervise(s, 1.32, Receipts(1.32, 1.32, 1.32, 1.32), Mode.IMPEDANCE, True, CFG)
    assert not s.latched and v.mode == Mode.IMPEDANCE and s.reset_count == 2


def test_estop_latches_until_reset_with_other_mode():
    s, v = supervise(SafetyState(), 1.0, FRESH, Mode.ESTOP, False, CFG)
    assert v.mode == Mode.ESTOP and not v.enable
    s, v = supervise(s, 1.0, FRESH, Mode.IMPEDANCE, False, CFG)
    assert v.mode == Mode.ESTOP
    s, v = supervise(s, 1.0, FRESH, Mode.ESTOP, True, CFG)
    assert v.mode == Mode.ESTOP
    s, v = supervise(s, 1.0, FRESH, Mode.IMPEDANCE, True, CFG)
    assert v.mode == Mode.IMPEDANCE and not s.latched


def test_command_stale_holds_with_default_gains():
    _, v = supervise(SafetyState(), 1.3, Receipts(1.3, 1.3, 1.0, 1.3), Mode.PD, False, CFG)
    assert v.mode == Mode.IMPEDANCE and v.default_gains and v.faults & Fault.COMMAND_STALE
    _, v = supervise(SafetyState(), 1.3, Receipts(1.3, 1.3, 1.0, 1.3), Mode.DAMPING, False, CFG)
    assert v.mode == Mode.DAMPING and not v.default_gains


def test_clamp_torque():
    tau, sat = clamp_torque(np.array([13.0, -20.0, 1.0]), 12.0)
    np.testing.assert_array_equal(tau, [12.0, -12.0, 1.0])
    np.testing.assert_array_equal(sat, [True, True, False])
    tau, sat = clamp_torque(np.array([np.nan, np.inf, 0.0]), 12.0)
    np.testing.assert_array_equal(tau, [0.0, 0.0, 0.0])
    assert sat[0] and sat[1]


def test_joint_limit_damping_only_near_and_towards_the_limit():
    lo, hi, m, c = CFG.lower, CFG.upper, CFG.limit_margin, 0.5
    q = P.Q_EQUILIBRIUM[1:].copy()
    tau, active = joint_limit_damping(q, np.ones(3), lo, hi, m, c)
    assert not active.any() and np.all(tau == 0)
    q[0] = hi[0] - 0.5 * m  # halfway into the margin below the upper limit
    tau, active = joint_limit_damping(q, np.array([2.0, 0, 0]), lo, hi, m, c)
    assert active[0] and np.isclose(tau[0], -0.5 * c * 2.0)
    tau, _ = joint_limit_damping(q, np.array([-2.0, 0, 0]), lo, hi, m, c)
    assert tau[0] == 0.0  # moving away from the limit: free


def test_damping_torque():
    np.testing.assert_allclose(damping_torque(np.array([1.0, -2.0, 0.0]), 0.3), [-0.3, 0.6, 0.0])


def test_torso_stale_never_energises_a_disabled_spine():
    rx = Receipts(torso=None, feedback=1.0, command=1.0, heartbeat=1.0)
    _, v = supervise(SafetyState(), 1.0, rx, Mode.DISABLED, False, CFG)
    assert v.mode == Mode.DISABLED and not v.enable and v.faults & Fault.TORSO_STALE
    _, v = supervise(SafetyState(), 1.0, rx, Mode.JOINT_TORQUE, False, CFG)
    assert v.mode == Mode.DAMPING and v.enable


def test_three_joint_fast_paths_equal_the_general_loop() -> None:
    """clamp_torque_list and joint_limit_damping_list return early for the usual tick (three values, all
    inside); one joint at a time takes the general loop, which must agree bit for bit, NaN included."""
    import math as _m

    import numpy as _np

    from spine_module.safety import clamp_torque_list, joint_limit_damping_list

    rng = _np.random.default_rng(7)
    lower, upper, margin, c = [-1.0, -0.5, -2.0], [1.0, 0.8, 0.5], 0.1, 3.0
    specials = [_m.nan, _m.inf, -_m.inf, -0.0]
    for trial in range(3000):
        tau = rng.uniform(-12, 12, 3).tolist()
        q = [rng.uniform(lo - 0.2, hi + 0.2) for lo, hi in zip(lower, upper, strict=True)]
        dq = rng.normal(0, 1, 3).tolist()
        if trial % 10 == 0:
            tau[trial % 3] = specials[trial % 4]
            q[(trial + 1) % 3] = specials[(trial + 1) % 4]
        out, sat = clamp_torque_list(tau, 10.0)
        one = [clamp_torque_list([t], 10.0) for t in tau]
        assert [o[0][0] for o in one] == out
        assert [o[1][0] for o in one] == list(sat)
        extra, near = joint_limit_damping_list(q, dq, lower, upper, margin, c)
        one = [joint_limit_damping_list([q[i]], [dq[i]], [lower[i]], [upper[i]], margin, c) for i in range(3)]
        assert list(near) == [o[1][0] for o in one]
        assert _np.array_equal(_np.array(extra), _np.array([o[0][0] for o in one]), equal_nan=True)
        assert [_m.copysign(1, v) for v in extra] == [_m.copysign(1, o[0][0]) for o in one]
