"""The base's linear motion in the torso estimate (WorldConfig.base_motion): the constant-twist
acceleration a = w x v, each engine's body twist, and both spine paths (direct, node) handing it to the
law."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from sparc_quad.robot_side.quad import NodeSpine
from sparc_quad.sim.imu import ImuConfig
from sparc_quad.sim.quadruped_world import (
    BASE_MOTIONS,
    Estimator,
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
EXACT = ImuConfig(q1_noise_rad=0.0, dq1_noise_rad_s=0.0, ddq1_noise_rad_s2=0.0, delay_steps=1)
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
    assert BASE_MOTIONS == ("fixed", "constant-twist", "authors-cvel")
    assert WorldConfig().base_motion == "fixed"
    pytest.importorskip("mujoco")
    with pytest.raises(ValueError, match="base_motion"):
        make_world(WorldConfig(host="spined-dog", engine="mujoco", base_motion="sliding"))
    # MuJoCo's cvel is one step behind qpos after mj_step: the authors' reading needs a delay of a step
    cfg = WorldConfig(host="spined-dog", engine="mujoco", base_motion="authors-cvel")
    with pytest.raises(ValueError, match="delay_steps >= 1"):
        make_world(replace(cfg, imu=replace(cfg.imu, delay_steps=0)))


@pytest.mark.parametrize("delay", [1, 2, 3])
def test_a_lagged_twist_is_filed_under_its_own_state(delay):
    """A twist one step old (MuJoCo's cvel: at update k the state k - 1's, at update 0 state 0's) comes out
    with the estimate's delay, as a present-state twist does: at update k the twist of state k - delay."""
    twists = [(0.5 + 0.1 * k, 0.0, 0.02 * k, 0.0, 1.0 - 0.05 * k, 0.01 * k) for k in range(12)]
    imu = ImuConfig(q1_noise_rad=0.0, dq1_noise_rad_s=0.0, ddq1_noise_rad_s2=0.0, delay_steps=delay)
    lagged = Estimator(imu, 1e-3, np.random.default_rng(0), "authors-cvel", twist_lag_steps=1)
    present = Estimator(imu, 1e-3, np.random.default_rng(0), "authors-cvel")
    for k in range(12):
        got = lagged.update(0.01 * k, 0.1 * k, twists[max(0, k - 1)])
        want = present.update(0.01 * k, 0.1 * k, twists[k])
        assert got.base_accel == constant_twist_accel(twists[max(0, k - delay)])
        assert (got.q1, got.dq1, got.ddq1, got.base_accel) == (want.q1, want.dq1, want.ddq1, want.base_accel)


def _cvel_of(m, qpos, qvel, body: int) -> np.ndarray:
    """cvel's definition, from the state: the body's angular velocity and the velocity of the point at the
    robot's centre of mass moving with it, v_origin + w x (com - origin), world axes."""
    import mujoco

    d = mujoco.MjData(m)
    d.qpos[:], d.qvel[:] = qpos, qvel
    mujoco.mj_forward(m, d)
    rot = d.xmat[body].reshape(3, 3)
    w = rot @ qvel[3:6]  # the free joint's angular velocity is body-frame
    return np.r_[w, qvel[0:3] + np.cross(w, d.subtree_com[body] - d.xpos[body])]


def test_mujoco_estimate_carries_w_cross_v_of_cvel_one_step_late():
    """"authors-cvel" in MuJoCo: at every step the estimate's base acceleration is w x v of the hind body's
    cvel as the authors' code reads it then (d.cvel: the state before the last step, the first state's at
    step 0), and that cvel is the COM point's velocity of the state one step back (world axes)."""
    pytest.importorskip("mujoco")
    cfg = WorldConfig(host="spined-dog", engine="mujoco", base_motion="authors-cvel", init_vx_m_s=0.7,
                      imu=EXACT)
    with make_world(cfg) as w:
        w.set_torques([0.5, -0.3, 0.2], {k: (0.0, 0.4, -0.6) for k in w.legs})
        hind = w._base
        states = [(w.data.qpos.copy(), w.data.qvel.copy())]
        for k in range(40):
            cvel = w.data.cvel[hind].copy()
            np.testing.assert_allclose(cvel, _cvel_of(w.model, *states[max(0, k - 1)], hind), atol=1e-12)
            assert w.authors_twist() == (*cvel[3:6].tolist(), *cvel[0:3].tolist())
            acc = w.estimate().base_accel
            assert acc == constant_twist_accel(w.authors_twist())
            np.testing.assert_allclose(acc, np.cross(cvel[0:3], cvel[3:6]), rtol=0, atol=1e-14)
            w.step()
            states.append((w.data.qpos.copy(), w.data.qvel.copy()))
        # not the body twist: the COM point's velocity, world axes
        assert np.abs(np.array(w.authors_twist()[:3]) - np.array(w.base_twist()[:3])).max() > 1e-3


def test_pybullet_authors_twist_is_the_com_point_velocity():
    """pybullet's authors' twist is the present state's velocity of the whole robot's COM point moving with
    the hind body (world axes); with the joints at rest every link moves with it, so it is the robot's COM
    velocity. Through the estimate (delay 1) it is the previous step's, as MuJoCo's cvel is."""
    pb = pytest.importorskip("pybullet")
    cfg = WorldConfig(host="spined-dog", engine="pybullet", base_motion="authors-cvel", imu=EXACT)
    with make_world(cfg) as w:
        c, robot = w.client, w.robot
        pb.resetBaseVelocity(robot, [0.6, -0.1, 0.2], [0.3, -1.5, 0.4], physicsClientId=c)
        w.read()
        links = range(pb.getNumJoints(robot, physicsClientId=c))
        mass = [pb.getDynamicsInfo(robot, i, physicsClientId=c)[0] for i in (-1, *links)]
        vel = [pb.getBaseVelocity(robot, physicsClientId=c)[0]]
        vel += [pb.getLinkState(robot, i, computeLinkVelocity=1, computeForwardKinematics=1,
                                physicsClientId=c)[6] for i in links]
        com_vel = (np.array(mass)[:, None] * np.array(vel)).sum(axis=0) / sum(mass)
        tw = w.authors_twist()
        np.testing.assert_allclose(tw[:3], com_vel, atol=1e-9)
        np.testing.assert_allclose(tw[3:], w.base_omega, atol=1e-15)
        w.set_torques([0.0, 0.0, 0.0], {k: (0.0, 0.0, 0.0) for k in w.legs})
        w.estimate()
        prev = tw
        for _ in range(5):
            w.step()
            assert w.estimate().base_accel == constant_twist_accel(prev)
            prev = w.authors_twist()


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
        assert spine.body.torso().base_accel_valid
        spine.begin(EstimatorOutput(0.0, 0.1, 7.0), Q_EQ, [0.0, 0.0, 0.0], 0.001)
        spine.finish()
        assert not spine.body.torso().base_accel_valid
    finally:
        spine.close()
    assert seen, "the node ran no impedance step"
    assert seen[0][1].tolist() == list(ACC) and seen[0][0] == (7.0 if torso_accel else 0.0)
    assert seen[-1][1] is None  # not valid: the fixed-origin law (the node hands the controller none)
