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


def _node_reference(tau, q, dq, lim: safety.SafetyConfig) -> tuple[list[float], bool, bool]:
    """What the node's tick does to a controller torque: joint-limit damping added where a joint is near
    its limit, then the clamp."""
    extra, near = safety.joint_limit_damping_list(list(q), list(dq), lim.lower.tolist(), lim.upper.tolist(),
                                                  lim.limit_margin, lim.joint_limit_damping)
    if any(near):
        tau = [a + b for a, b in zip(tau, extra, strict=True)]
    out, sat = safety.clamp_torque_list(list(tau), lim.torque_limit)
    return out, any(near), any(sat)


def test_direct_spine_limits_equal_the_node_bit_for_bit():
    """The direct path's output stage is the node's (`safety.limit_torque`): the same doubles (NaN
    included) on states clear of the margins, inside them, beyond the limits, saturating and non-finite."""
    lim = safety.SafetyConfig()
    gains = SpineGains(k=(300.0, 300.0, 6.0), d=(3.0, 3.0, 0.1))
    spine, raw = DirectSpine(gains), make_spine_drive(gains)
    rng = np.random.default_rng(3)
    lo, hi = lim.lower, lim.upper
    near = clamped = 0
    for k in range(1500):
        q = rng.uniform(lo - 0.3, hi + 0.3) if k % 3 else rng.uniform(lo + 0.1, hi - 0.1)
        dq = rng.normal(0.0, 3.0, 3) * (k % 7 != 0)
        if k % 97 == 0:
            q[k % 3] = np.nan
        q, dq = q.tolist(), dq.tolist()
        spine.begin(EST, q, dq, 0.0)
        got = spine.finish()
        tau = raw.step(np.array([0.0, *q]), np.array([0.0, *dq]), 0.0).tolist()
        want, was_near, was_clamped = _node_reference(tau, q, dq, lim)
        assert np.array_equal(got, want, equal_nan=True), (q, dq, tau)
        assert np.array_equal(np.signbit(got), np.signbit(want)), (q, dq, tau)
        near += was_near
        clamped += was_clamped
    assert near > 50 and clamped > 50, (near, clamped)


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
