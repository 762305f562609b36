"""The base's linear motion in the torso estimate (WorldConfig.base_motion): the constant-twist
acceleration a = w x v, each engine's body twist, and both spine paths (direct, node) handing it to the
law."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from sparc_quad.robot_side.quad import NodeSpine
from sparc_quad.sim.quadruped_world import (
    BASE_MOTIONS,
    EstimatorOutput,
    QuadWorld,
    WorldConfig,
    constant_twist_accel,
    make_world,
)
from sparc_quad.sim.sim_spine import DirectSpine
from sparc_quad.sim.spine_drive import SpineGains
from spine_module import params as P
from spine_module.control import ImpedanceController
from spine_module.model import SpineModel

Q_EQ = P.Q_EQUILIBRIUM[1:].tolist()
ACC = (1.25, 0.0, -3.5)


def test_constant_twist_acceleration_is_w_cross_v_at_the_point():
    rng = np.random.default_rng(0)
    for _ in range(50):
        v, w, r = rng.normal(size=3), rng.normal(size=3), rng.normal(size=3)
        np.testing.assert_allclose(constant_twist_accel((*v, *w)), np.cross(w, v), atol=1e-14)
        np.testing.assert_allclose(constant_twist_accel((*v, *w), tuple(r)), np.cross(w, v + np.cross(w, r)),
                                   atol=1e-13)
    assert constant_twist_accel((1.0, 0.0, 0.0, 0.0, -2.0, 0.0)) == (0.0, 0.0, 2.0)  # pitching up, moving on


@pytest.mark.parametrize("engine", ["mujoco", "pybullet"])
def test_world_estimate_carries_the_constant_twist_acceleration(engine):
    pytest.importorskip(engine)
    host = "spined-dog" if engine == "mujoco" else "solo12"
    cfg = WorldConfig(host=host, engine=engine, base_motion="constant-twist", init_vx_m_s=0.7)
    cfg = replace(cfg, imu=replace(cfg.imu, delay_steps=0))
    with make_world(cfg) as w:
        w.set_torques([0.0, 0.0, 0.0], {k: (0.0, 0.0, 0.0) for k in w.legs})
        for _ in range(30):
            w.step()
        twist = w.base_twist()
        generic = QuadWorld.base_twist(w)  # from base_vel, base_omega, base_rot (world axes)
        np.testing.assert_allclose(twist, generic, atol=1e-12)
        R = np.array(w.base_rot).reshape(3, 3)
        np.testing.assert_allclose(twist[:3], R.T @ np.array(w.base_vel), atol=1e-12)
        est = w.estimate()
        assert est.base_accel == constant_twist_accel(twist)
        assert abs(est.base_accel[0]) + abs(est.base_accel[2]) > 0.0
    with make_world(replace(cfg, base_motion="fixed")) as w:
        assert w.estimate().base_accel is None


def test_base_motion_is_checked():
    assert BASE_MOTIONS == ("fixed", "constant-twist") and WorldConfig().base_motion == "fixed"
    pytest.importorskip("mujoco")
    with pytest.raises(ValueError, match="base_motion"):
        make_world(WorldConfig(host="spined-dog", engine="mujoco", base_motion="sliding"))


def test_direct_spine_hands_the_estimate_to_the_law():
    """The direct spine's torque with a base acceleration is the controller's with it (and without one the
    controller's fixed-origin torque)."""
    ref = ImpedanceController(SpineModel(), backend="pinocchio")
    q, dq = np.r_[0.1, Q_EQ], np.r_[0.5, 0.0, 0.0, 0.0]
    for acc in (ACC, None):
        spine = DirectSpine(SpineGains())
        spine.begin(EstimatorOutput(0.1, 0.5, 0.0, acc), Q_EQ, [0.0, 0.0, 0.0], 0.0)
        want = ref.step(q, dq, 0.0, None if acc is None else np.array(acc)).tau
        np.testing.assert_allclose(spine.finish(), want, atol=1e-12)
    spine = DirectSpine(SpineGains())
    spine.begin(EstimatorOutput(0.1, 0.5, 0.0, ACC), Q_EQ, [0.0, 0.0, 0.0], 0.0)
    moved = list(spine.finish())
    spine.begin(EstimatorOutput(0.1, 0.5, 0.0), Q_EQ, [0.0, 0.0, 0.0], 0.0)
    assert moved != list(spine.finish())


@pytest.mark.parametrize("torso_accel", [True, False])
def test_node_spine_sends_the_base_acceleration(torso_accel):
    """Through the node (in process, over the codec) the controller gets the estimate's acceleration as the
    direct path does, with or without q̈1; an estimate without one sends base_accel_valid False (0)."""
    spine = NodeSpine.inprocess(SpineGains(), torso_accel=torso_accel)
    seen = []
    ctrl = spine.node.ctrl.impedance
    step = ctrl.step

    def spy(q, dq, ddq1=0.0, base_accel=None):
        seen.append((ddq1, None if base_accel is None else np.array(base_accel)))
        return step(q, dq, ddq1, base_accel)

    ctrl.step = spy
    try:
        spine.begin(EstimatorOutput(0.0, 0.1, 7.0, ACC), Q_EQ, [0.0, 0.0, 0.0], 0.0)
        spine.finish()
        assert spine.plant.torso().base_accel_valid
        spine.begin(EstimatorOutput(0.0, 0.1, 7.0), Q_EQ, [0.0, 0.0, 0.0], 0.001)
        spine.finish()
        assert not spine.plant.torso().base_accel_valid
    finally:
        spine.close()
    assert seen, "the node ran no impedance step"
    assert seen[0][1].tolist() == list(ACC) and seen[0][0] == (7.0 if torso_accel else 0.0)
    assert seen[-1][1].tolist() == [0.0, 0.0, 0.0]
