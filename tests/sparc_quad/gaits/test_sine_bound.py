"""Gait A as the SPARC authors run it: call clock, foot arc, steering sign, held torques, frequency
adaptation, checked against MuJoCo's own clock, forward kinematics on the spined dog's MJCF and the
re-expressed authors' controller (tests/reference/authors_bound.py)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sparc_quad.gaits.sine_bound import LEGS, SineBoundController, SineBoundParams
from sparc_quad.sim.control_clock import ControlClock
from tests.paths import ROOT

mujoco = pytest.importorskip("mujoco")

MJCF = ROOT / "robots" / "spined_dog" / "spined_dog.xml"


@pytest.fixture(scope="module")
def world():
    from sparc_quad.sim.quadruped_world import WorldConfig, make_world

    w = make_world(WorldConfig(host="spined-dog", engine="mujoco"))
    yield w
    w.close()


def test_control_clock_calls_where_the_authors_mujoco_loop_does():
    m = mujoco.MjModel.from_xml_string('<mujoco><option timestep="0.001"/><worldbody/></mujoco>')
    d = mujoco.MjData(m)
    theirs, last = [], 0.0
    for k in range(3000):
        if d.time - last >= 1.0 / 200.0:
            theirs.append(k)
            last = d.time
        mujoco.mj_step(m, d)
    clock = ControlClock(1.0 / 200.0, 0.001)
    ours = [k for k in range(3000) if clock.tick()]
    assert ours == theirs
    assert ours[0] == 5  # zero torque for the first 5 ms
    gaps = set(np.diff(ours).tolist())
    assert gaps == {5, 6}  # the float clock: 5 or 6 steps, not every 5
    assert 175.0 < len(ours) / 3.0 < 190.0


def test_the_raised_arc_moves_the_foot_back_to_front_on_the_dog(world):
    """FK on the dog's MJCF of the joint angles the authors' IK gives: the swing half (sin phi > 0) runs
    from the back to the front of the hip; the port's robot-frame targets and IK give the same angles."""
    from tests.reference.authors_bound import AuthorsBoundConfig, AuthorsGait

    m = mujoco.MjModel.from_xml_path(str(MJCF))
    d = mujoco.MjData(m)
    theirs = AuthorsGait(AuthorsBoundConfig(step_length_m=0.08))
    ours = SineBoundController(world, SineBoundParams(step_length_m=0.08))
    hip, foot = m.body("hind_left_leg_upper").id, m.body("hind_left_foot").id
    qa, qb = (m.jnt_qposadr[m.joint(f"joint_hind_left_leg_{n}").id] for n in ("upper", "lower"))
    xs = []
    for phase in np.linspace(0.05, math.pi - 0.05, 12):
        q = theirs.joint_targets(phase / theirs.w)
        d.qpos[qa], d.qpos[qb] = q[0], q[1]
        mujoco.mj_kinematics(m, d)
        rel = d.xmat[1].reshape(3, 3).T @ (d.xpos[foot] - d.xpos[hip])
        xs.append(rel[0])
        x, z = ours.foot_target("HL", phase)
        assert rel[0] == pytest.approx(x, abs=1e-9) and rel[2] == pytest.approx(z, abs=1e-9)
        for leg, (i, j) in zip(LEGS, ((0, 1), (2, 3), (4, 5), (6, 7)), strict=True):
            h, k = world.leg_ik(leg, *ours.foot_target(leg, phase))
            assert (h, k) == pytest.approx((q[i], q[j]), abs=1e-9)
    assert np.all(np.diff(xs) > 0) and xs[0] < -0.07 and xs[-1] > 0.07  # back to front
    literal = SineBoundController(world, SineBoundParams(step_length_m=0.08, variant="literal"))
    assert literal.foot_target("HL", 0.5)[0] == pytest.approx(-ours.foot_target("HL", 0.5)[0])


def test_steering_has_the_authors_sign(world):
    """Their dir_kp = -0.3, dir_kd = -0.1 on e = -yaw: yawed +0.1 rad, cmd = 0.04, right strides 1.04."""
    yaw0 = world.yaw
    try:
        world.yaw = 0.1
        ours = SineBoundController(world, SineBoundParams())
        ours._steer()
        assert ours.stride_scale["R"] == pytest.approx(1.04) and ours.stride_scale["L"] == pytest.approx(0.96)
        literal = SineBoundController(world, SineBoundParams(variant="literal"))
        literal._steer()
        assert literal.stride_scale["R"] == pytest.approx(0.96)
    finally:
        world.yaw = yaw0


def test_torques_are_zero_until_the_first_call_then_held(world):
    ctrl = SineBoundController(world, SineBoundParams())
    outs = []
    for _ in range(12):
        out = ctrl.step(0.0)
        outs.append(tuple(v for leg in LEGS for v in out[leg]))
    assert all(o == (0.0,) * 12 for o in outs[:5])
    assert outs[5] != outs[4] and outs[6:10] == [outs[5]] * 4
    assert ctrl.clock.calls == 2 and outs[10 if ctrl.clock.last_call_s < 0.0105 else 11] != outs[5]


def test_frequency_adaptation_lowers_f_by_the_lag_at_the_next_cycle(world):
    """A synthetic spine x whose peak sits at gait phase 1.0 rad until 4 s, then 0.3 rad later: the target
    is learnt over 2-4 s, then f is queued at 0.5 * (3.1 - 0.3) + 0.5 * 3.1 = 2.95 Hz and applied at the
    next phase wrap; never below 2.8 Hz."""
    ctrl = SineBoundController(world, SineBoundParams(adapt_frequency=True))
    changes_at_wrap = []
    fs = []
    for _ in range(8000):
        before = ctrl.frequency_hz
        ctrl.step(0.0)
        t = ctrl.clock.now_s
        shift = 1.0 if t < 4.0 else 1.3
        ctrl.observe_spine(t, 0.27 + 0.01 * math.cos(ctrl.gait_phase - shift))
        if ctrl.frequency_hz != before:
            changes_at_wrap.append(ctrl.gait_phase < 2 * math.pi * 3.2 * 0.0061)
        fs.append(ctrl.frequency_hz)
    assert ctrl.target_peak_phase is not None
    assert ctrl.frequency_changes, "no frequency change"
    t0, f0 = ctrl.frequency_changes[0]
    assert t0 > 4.0 and f0 == pytest.approx(2.95, abs=0.02)
    assert all(changes_at_wrap)
    assert min(fs) >= 2.8 - 1e-12
    off = SineBoundController(world, SineBoundParams(adapt_frequency=False))
    for _ in range(6000):
        off.step(0.0)
        off.observe_spine(off.clock.now_s, 0.27 + 0.01 * math.cos(off.gait_phase - 1.3))
    assert off.frequency_hz == 3.1 and not off.frequency_changes


def test_start_pose_is_the_trajectory_at_full_amplitude(world):
    ctrl = SineBoundController(world, SineBoundParams(step_length_m=0.1, start_spine_q_rad=(-0.6, 1.2, -0.6),
                                                      start_base_height_m=0.24))
    spine, legs, height = ctrl.start_pose()
    assert spine == (-0.6, 1.2, -0.6) and height == 0.24
    # their main_robot.py poses the legs before switching the trot to the bound: the right legs start
    # half a cycle away from where the bound puts them
    for leg in LEGS:
        shift = math.pi if leg[1] == "R" else 0.0
        assert legs[leg] == pytest.approx(world.leg_ik(leg, *ctrl.foot_target(leg, shift)))
    assert ctrl.foot_target("HL", 0.0)[0] == pytest.approx(-0.1)  # full amplitude at t = 0
    bound = SineBoundController(world, SineBoundParams(step_length_m=0.1,
                                                       start_leg_offsets_rad=(0.0, 0.0, math.pi, math.pi)))
    for leg in LEGS:
        assert bound.start_leg_angles()[leg] == pytest.approx(world.leg_ik(leg, *ctrl.foot_target(leg, 0.0)))
    assert SineBoundController(world, SineBoundParams(variant="literal")).start_pose() is None


def test_bad_variant_is_named():
    with pytest.raises(ValueError, match="variant"):
        SineBoundParams(variant="other").validate()


@pytest.mark.parametrize("engine", ["mujoco", "pybullet"])
def test_world_starts_where_the_gait_says(engine):
    """The authors' start through `world.set_start` in either engine: spine, legs and base height."""
    from sparc_quad.sim.quadruped_world import make_world
    from tests.scenarios import authors_config

    cfg = authors_config(0.1, 800.0, 1.0, engine=engine)
    w = make_world(cfg.world)
    try:
        ctrl = SineBoundController(w, cfg.gait)
        w.set_start(*ctrl.start_pose())
        assert w.q_spine == pytest.approx([-0.6, 1.2, -0.6], abs=1e-9)
        assert w.base_pos[2] == pytest.approx(0.24, abs=1e-9)
        for leg, (h, k) in ctrl.start_leg_angles().items():
            st = w.leg_state(leg)
            assert (st.hfe, st.kfe) == pytest.approx((h, k), abs=1e-9)
    finally:
        w.close()
