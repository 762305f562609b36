"""Gait C's pieces against what their code does: the IK branch their reference picks, stance torques as
J^T F of the leg's own kinematics, the touchdown law, the 2 ms call clock."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest

from sparc_quad.gaits.authors_raibert import (
    HALF_PI,
    LEGS,
    NOMINAL_Q,
    AuthorsRaibertController,
    AuthorsRaibertParams,
)

L1 = L2 = 0.151


def _foot(q_robot: tuple[float, float]) -> np.ndarray:
    """The foot in their leg frame (x = the robot's -x, z up) from robot-frame joint angles."""
    a = q_robot[0] - HALF_PI
    return np.array([L1 * math.cos(a) + L2 * math.cos(a + q_robot[1]),
                     L1 * math.sin(a) + L2 * math.sin(a + q_robot[1])])


class FakeWorld:
    """What gait C reads of a world: legs without abduction, jq/jdq, the body states."""

    def __init__(self, q_legs: dict[str, tuple[float, float]], body=None):
        self.meta = {"legs": {k: {"haa": None, "thigh_m": L1, "shank_m": L2} for k in LEGS},
                     "leg_torque_limit_nm": 120.0}
        self.cfg = SimpleNamespace(dt_s=0.001)
        self.leg_torque_limit_nm = 120.0
        self.jq = [0.0] * 8 + [0.0]
        self.jdq = [0.0] * 9
        self._slots = {k: (8, 2 * i, 2 * i + 1) for i, k in enumerate(LEGS)}  # 8: the absent HAA
        for k, (h, kn) in q_legs.items():
            self.jq[2 * LEGS.index(k)], self.jq[2 * LEGS.index(k) + 1] = h, kn
        ident = (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0)
        v = (0.9, 0.0, 0.0)
        self.body = body or ((0.0, 0.0, 0.23), ident, v, (0.0, 0.0, 0.0), ident, v)

    def leg_joint_slots(self, key):
        return self._slots[key]

    def authors_body_states(self):
        return self.body


def _nominal_world() -> FakeWorld:
    return FakeWorld({k: NOMINAL_Q[i] for i, k in enumerate(LEGS)})


@pytest.mark.parametrize("x", [-0.15, -0.05, 0.0, 0.08, 0.19])
def test_ik_reaches_the_target_on_their_branch(x):
    """Hind legs knee-back (knee > 0), front legs knee-forward (knee < 0) over the stride, as their reference
    (nominal + pi/2) selects; the solution puts the foot on the target."""
    g = AuthorsRaibertController(_nominal_world())
    for i in range(4):
        ref = (NOMINAL_Q[i][0] + HALF_PI, NOMINAL_Q[i][1])
        q1m, q2 = g._ik(x, -0.23, ref)
        q = (q1m + HALF_PI, q2)
        assert np.allclose(_foot(q), (x, -0.23), atol=1e-12)
        assert (q2 > 0) == (i < 2)


def test_ik_out_of_reach_returns_their_reference():
    """Their IK returns the reference (nominal + pi/2) for a target beyond 0.302 m: kept as they have it."""
    g = AuthorsRaibertController(_nominal_world())
    ref = (NOMINAL_Q[0][0] + HALF_PI, NOMINAL_Q[0][1])
    assert g._ik(0.2, -0.23, ref) == ref  # 0.305 m from the hip


def test_stance_torque_is_jacobian_transpose_force():
    """The hind legs in stance (gait phase in (pi, 2 pi)): tau = J^T F, J the derivative of the leg's own
    forward kinematics, F inside their force clips."""
    p = AuthorsRaibertParams(speed_m_s=0.9, start_phase_rad=1.5 * math.pi)  # hind in stance at t ~ 0
    q = {k: (NOMINAL_Q[i][0] + 0.1, NOMINAL_Q[i][1] - 0.2) for i, k in enumerate(LEGS)}
    g = AuthorsRaibertController(FakeWorld(q), p)
    g._compute(0.002)
    assert not g.in_swing[0] and not g.in_swing[1]
    h = 1e-7
    for key in LEGS[:2]:
        qq = np.array(q[key])
        jac = np.column_stack([(_foot(qq + h * e) - _foot(qq - h * e)) / (2 * h) for e in np.eye(2)])
        tau = np.array(g.out[key][1:])
        force = np.linalg.solve(jac.T, tau)
        assert -80.0 <= force[1] <= -2.0 and -20.0 <= force[0] <= 40.0  # their clips, in their frame
        assert np.allclose(jac.T @ force, tau, atol=1e-9)


def test_touchdown_law_and_front_sign():
    """At lift-off x_td = 0.5 T_stance v_cmd + k (v - v_cmd), clipped to 0.2 m, negated for the front legs."""
    p = AuthorsRaibertParams(speed_m_s=0.3)  # the ramp starts at 0.3: v_cmd is 0.3 throughout
    g = AuthorsRaibertController(_nominal_world(), p)
    g.stance_avg = [1.1, 0.7]
    t_stance = 0.5 / p.frequency_hz
    g._compute(0.01)  # hind legs swing at phase in (0, pi): they lift off at this call
    expect_hind = 0.5 * t_stance * 0.3 + 0.08 * (1.1 - 0.3)
    assert g.x_touchdown[0] == pytest.approx(expect_hind, abs=1e-12)
    pos, rot, _, w, front_rot, _ = g.w.body  # the hind stance at 10 m/s: its average sets the next touchdown
    g.w.body = (pos, rot, (10.0, 0.0, 0.0), w, front_rot, (10.0, 0.0, 0.0))
    g._compute(0.5 / p.frequency_hz + 0.01)  # front legs lift off half a cycle later
    assert g.stance_avg[1] == pytest.approx(0.9)  # the front stance's one sample, at the first call
    assert g.x_touchdown[2] == pytest.approx(-(0.5 * t_stance * 0.3 + 0.12 * (0.9 - 0.3)), abs=1e-12)
    g._compute(1.0 / p.frequency_hz + 0.01)
    assert g.x_touchdown[0] == pytest.approx(p.max_stride_m)


def test_calls_on_their_float_clock():
    """The 2 ms rule on MuJoCo's float clock (time += 0.001 each step; a call when time - last >= 0.002):
    every 2 or 3 steps, about 416 calls per second over 10 s, none at t = 0 (zero torque until the first)."""
    g = AuthorsRaibertController(_nominal_world())
    out0 = g.step(0.0)
    assert all(v == (0.0, 0.0, 0.0) for v in out0.values())
    for _ in range(9999):
        g.step(0.0)
    time, last, calls = 0.0, 0.0, 0
    for _ in range(10000):
        if time - last >= 0.002:
            calls, last = calls + 1, time
        time += 0.001
    assert g.clock.calls == calls
    assert 4000 <= calls <= 4300
