"""The spine in the simulation: one interface (`SimSpine`), the node as the reference, the direct call as
its fast configuration with the node's joint-limit damping and torque clamp."""

from __future__ import annotations

import numpy as np
import pytest

from sparc_quad.metrics import saturated
from sparc_quad.robot_side.quad import NodeSpine
from sparc_quad.sim.quadruped_world import EstimatorOutput
from sparc_quad.sim.sim_spine import DirectSpine, SimSpine
from sparc_quad.sim.spine_drive import SpineGains, make_spine_drive
from spine_module import params as P
from spine_module import safety

EST = EstimatorOutput(q1=0.0, dq1=0.0, ddq1=0.0)
Q_EQ = P.Q_EQUILIBRIUM[1:].tolist()


@pytest.mark.parametrize("variant", ["impedance", "passive", "rigid", "rigid-impedance"])
def test_direct_spine_is_a_sim_spine(variant):
    spine = DirectSpine(SpineGains(), variant=variant)
    assert isinstance(spine, SimSpine)
    assert spine.driver == variant and spine.name == "direct"
    assert spine.actuated == (variant in ("impedance", "rigid-impedance"))
    spine.begin(EST, Q_EQ, [0.0, 0.0, 0.0], 0.0)
    tau = spine.finish()
    assert len(tau) == 3 and all(np.isfinite(tau))
    assert spine.node_states() is None


def test_node_spine_is_a_sim_spine():
    spine = NodeSpine.inprocess(SpineGains())
    try:
        assert isinstance(spine, SimSpine)
        assert (spine.name, spine.driver, spine.actuated) == ("node", "node", True)
    finally:
        spine.close()


def test_direct_spine_clamps_as_the_node_does():
    """The controller's own output stage stops at 12 N*m; the limit damping added after it can push past
    that, and the node's clamp (here as there) brings the sum back to the motor's limit."""
    lim = safety.SafetyConfig()
    gains = SpineGains(k=(2e4, 2e4, 500.0), d=(10.0, 10.0, 1.0))
    q = Q_EQ.copy()
    q[1] = float(lim.upper[1]) - 0.2 * lim.limit_margin
    dq = [0.0, 30.0, 0.0]  # fast towards the limit: damping of about -12 N*m on top
    raw = make_spine_drive(gains).step(np.array([0.0, *q]), np.array([0.0, *dq]), 0.0)
    extra, _ = safety.joint_limit_damping_list(q, dq, lim.lower.tolist(), lim.upper.tolist(),
                                               lim.limit_margin, lim.joint_limit_damping)
    assert abs(raw[1] + extra[1]) > P.TORQUE_LIMIT_NM
    spine = DirectSpine(gains)
    spine.begin(EST, q, dq, 0.0)
    tau = spine.finish()
    assert abs(tau[1]) == pytest.approx(P.TORQUE_LIMIT_NM)
    # the run's metrics see the clamp in the logged torque (spine_saturation_share)
    assert saturated(np.array([tau]), P.TORQUE_LIMIT_NM)[0, 1]


def test_direct_spine_adds_the_node_joint_limit_damping():
    """Near a joint limit and moving towards it, the direct path adds the node's limit damping."""
    lim = safety.SafetyConfig()
    gains = SpineGains(k=(0.0, 0.0, 0.0), d=(0.0, 0.0, 0.0))  # no controller torque from the error
    q = Q_EQ.copy()
    q[1] = float(lim.upper[1]) - 0.2 * lim.limit_margin  # q3 inside the margin of its upper limit
    dq = [0.0, 1.0, 0.0]  # moving towards it
    ref = make_spine_drive(gains).step(np.array([0.0, *q]), np.array([0.0, *dq]), 0.0).tolist()
    spine = DirectSpine(gains)
    spine.begin(EST, q, dq, 0.0)
    tau = spine.finish()
    extra, active = safety.joint_limit_damping_list(q, dq, lim.lower.tolist(), lim.upper.tolist(),
                                                    lim.limit_margin, lim.joint_limit_damping)
    assert active[1] and extra[1] < 0
    assert tau[1] == pytest.approx(ref[1] + extra[1])
    assert tau[0] == pytest.approx(ref[0]) and tau[2] == pytest.approx(ref[2])


def test_passive_spring_is_not_clamped():
    """A physical spring is not a motor: neither clamp nor limit damping applies to it."""
    gains = SpineGains(k=(2e4, 2e4, 500.0), d=(10.0, 10.0, 1.0))
    q = [Q_EQ[0] + 0.4, Q_EQ[1] - 0.6, Q_EQ[2] + 0.4]
    spine = DirectSpine(gains, variant="passive")
    spine.begin(EST, q, [0.0, 0.0, 0.0], 0.0)
    assert max(abs(t) for t in spine.finish()) > P.TORQUE_LIMIT_NM


def test_skips_are_declared():
    assert any("soft start" in s for s in DirectSpine.SKIPS)
    assert any("watchdog" in s for s in DirectSpine.SKIPS)


def _node_reference(spine: DirectSpine, tau, q, dq) -> list[float]:
    """What the node does to a controller torque: joint-limit damping added, then the clamp."""
    extra, _ = safety.joint_limit_damping_list(list(q), list(dq), spine._lower, spine._upper, spine._margin,
                                               spine._c_limit)
    out, _ = safety.clamp_torque_list([a + b for a, b in zip(tau, extra, strict=True)], spine._tau_max)
    return out


def test_direct_spine_limits_equal_the_node_functions_bit_for_bit():
    """The direct path's inline shortcuts give the node functions' doubles (signed zeros and NaN included)
    on states clear of the margins, inside them, beyond the limits, saturating and non-finite."""
    spine = DirectSpine(SpineGains())
    rng = np.random.default_rng(3)
    lo, hi, lim = np.array(spine._lower), np.array(spine._upper), spine._tau_max
    cases = 0
    for k in range(3000):
        q = rng.uniform(lo - 0.3, hi + 0.3)
        dq = rng.normal(0.0, 3.0, 3) * (k % 7 != 0)  # some zero rates: signed zeros of the damping
        tau = rng.normal(0.0, lim, 3)
        if k % 97 == 0:
            q[k % 3] = np.nan
        if k % 89 == 0:
            tau[k % 3] = np.inf
        q, dq, tau = q.tolist(), dq.tolist(), tau.tolist()
        got, want = spine._node_limits(tau, q, dq), _node_reference(spine, tau, q, dq)
        assert np.array_equal(got, want, equal_nan=True), (q, dq, tau)
        assert np.array_equal(np.signbit(got), np.signbit(want)), (q, dq, tau)
        cases += 1
    assert cases == 3000


def test_clocked_drives_declare_it():
    """DirectSpine splits `tick`/`update` only for a drive that says it is clocked; every other drive
    inherits the defaults (runs at every step, `update` is `step`)."""
    gains = SpineGains()
    plain = make_spine_drive(gains)
    assert not plain.clocked and plain.tick()
    q, dq = np.array([0.0, *Q_EQ]), np.zeros(4)
    assert plain.update(q, dq, 0.0).tolist() == make_spine_drive(gains).step(q, dq, 0.0).tolist()
    held = make_spine_drive(gains, rate_hz=250.0, dt_s=1e-3)
    assert held.clocked
    assert [held.tick() for _ in range(8)] == [True, False, False, False] * 2
