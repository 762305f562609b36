"""The quadruped world behind one interface: both engines build every host by name, share conventions,
stand the robot on its feet, and give run_bound the same outputs."""

from __future__ import annotations

import sys

import numpy as np
import pytest

from sparc_quad.sim import engines
from sparc_quad.sim.hosts import HOSTS
from sparc_quad.sim.quadruped_world import WorldConfig, make_world

pytest.importorskip("mujoco")
pytest.importorskip("pybullet")
ENGINES = tuple(engines.ENGINES)


def test_unknown_engine_is_named():
    with pytest.raises(ValueError, match="engine must be one of pybullet, mujoco"):
        engines.world_class("bullet3")


def test_missing_engine_package_names_its_extra(monkeypatch):
    monkeypatch.setitem(sys.modules, "mujoco", None)  # as in an install without the extra
    monkeypatch.delitem(sys.modules, "sparc_quad.sim.engines.mujoco_world", raising=False)
    assert "pip install 'sparc-quad[mujoco]'" in engines.engine_error("mujoco")
    with pytest.raises(engines.EngineUnavailable, match=r"\[mujoco\] extra"):
        engines.world_class("mujoco")


def _hold_stand(world, steps: int) -> float:
    """PD on every joint to the initial stance (stiffness in proportion to the robot's mass); returns the
    mean total foot force over the second half, N."""
    q_sp, legs = world.stand_pose()
    kp = 8.0 * world.total_mass
    forces = []
    for i in range(steps):
        tau_legs = {}
        for k in world.legs:
            st = world.leg_state(k)
            h, kq = legs[k]
            tau_legs[k] = (-kp * st.haa - 0.5 * st.dhaa, kp * (h - st.hfe) - 0.5 * st.dhfe,
                           kp * (kq - st.kfe) - 0.5 * st.dkfe)
        tau_sp = [30 * (q - qq) - 0.5 * dq for q, qq, dq in zip(q_sp, world.q_spine, world.dq_spine,
                                                                 strict=True)]
        world.set_torques(tau_sp, tau_legs)
        world.step()
        if i >= steps // 2:
            forces.append(sum(world.contact_force.values()))
    return float(np.mean(forces))


@pytest.mark.parametrize("host", HOSTS)
def test_engines_stand_every_host_the_same_way(host):
    """Same mass, same initial state; after 0.5 s standing the feet carry the weight in both engines."""
    states = {}
    for engine in ENGINES:
        with make_world(WorldConfig(host=host, engine=engine, init_pitch_rad=0.05)) as w:
            assert w.engine == engine
            states[engine] = (w.total_mass, w.base_pos, w.q1, list(w.jq), w.front_weight_share())
            mean_force = _hold_stand(w, 500)
            assert not w.other_contact
            assert all(f > 0 for f in w.contact_force.values())
            assert mean_force == pytest.approx(w.total_mass * 9.81, rel=0.05)
            assert abs(w.roll) < 0.01 and abs(w.yaw) < 0.01
    (m_a, pos_a, q1_a, jq_a, share_a), (m_b, pos_b, q1_b, jq_b, share_b) = states.values()
    assert m_a == pytest.approx(m_b, rel=1e-9)
    np.testing.assert_allclose(pos_a, pos_b, atol=1e-9)
    assert q1_a == pytest.approx(q1_b, abs=1e-12) == pytest.approx(0.05, abs=1e-12)  # nose down
    np.testing.assert_allclose(jq_a, jq_b, atol=1e-12)
    assert share_a == pytest.approx(share_b, abs=1e-6)


@pytest.mark.parametrize("engine", ENGINES)
def test_pitch_rate_sign_and_locked_spine(engine):
    """A nose-down spin reads dq1 > 0 in both engines; a locked spine stays at its arch under torque."""
    with make_world(WorldConfig(host="spined-dog", engine=engine, lock_spine=True, gravity_m_s2=0.0)) as w:
        q0 = list(w.q_spine)
        zero = {k: (0.0, 0.0, 0.0) for k in w.legs}
        for _ in range(200):
            w.set_torques([5.0, -5.0, 5.0], zero)
            w.step()
        np.testing.assert_allclose(w.q_spine, q0, atol=0.02)
    with make_world(WorldConfig(host="spined-dog", engine=engine, gravity_m_s2=0.0)) as w:
        w.reset_stand(pitch_rad=0.0)
        if engine == "mujoco":
            w.data.qvel[4] = 1.0  # body-frame y = world y here
            w.data.qpos[2] += 0.5
        else:
            import pybullet as pb

            pos, orn = pb.getBasePositionAndOrientation(w.robot, physicsClientId=w.client)
            pb.resetBasePositionAndOrientation(w.robot, [pos[0], pos[1], pos[2] + 0.5], orn,
                                               physicsClientId=w.client)
            pb.resetBaseVelocity(w.robot, [0, 0, 0], [0, 1.0, 0], physicsClientId=w.client)
        w.set_torques([0.0] * 3, {k: (0.0, 0.0, 0.0) for k in w.legs})
        for _ in range(50):
            w.step()
        assert w.dq1 > 0.3 and w.q1 > 0.01


def test_mass_scale_scales_both_engines():
    for engine in ENGINES:
        with make_world(WorldConfig(host="spined-dog", engine=engine, mass_scale=1.05)) as w:
            assert w.total_mass == pytest.approx(1.05 * 5.792036, rel=1e-9)


def test_run_bound_has_the_same_outputs_on_both_engines(tmp_path):
    """A 1 s sine bound of the spined dog: same columns, same metric keys, finite state, on each engine."""
    from sparc_quad.bound.run import BoundConfig, run_bound, write_outputs
    from sparc_quad.gaits.sine_bound import SineBoundParams

    keys = {}
    for engine in ENGINES:
        cfg = BoundConfig(duration_s=1.0, gait=SineBoundParams(step_length_m=0.08),
                          world=WorldConfig(host="spined-dog", engine=engine), backend="python")
        res = run_bound(cfg)
        assert res.series.shape[0] > 0 and np.isfinite(res.series).all()
        paths = write_outputs(res, tmp_path / engine, plots=False)
        keys[engine] = (res.series.shape[1], sorted(res.metrics), sorted(p.name for p in paths))
        assert 0 < res.metrics["physics_wall_time_s"] < res.metrics["wall_time_s"]
    assert len(set(map(str, keys.values()))) == 1, keys


def test_study_trial_runs_on_the_mujoco_engine():
    """A study config names its engine and host like any other key; a wrong one is named."""
    from sparc_quad.study.trial import run_trial
    from tests.scenarios import trial_config as bound_config

    config = {"gait": "sine", "host": "spined-dog", "engine": "mujoco", "duration": 0.5, "step_length": 0.08,
              "variant": "authors"}
    assert bound_config(config).world.engine == "mujoco"
    out = run_trial(config)
    assert out["fell"] in (True, False)
    with pytest.raises(ValueError, match="engine: must be one of pybullet, mujoco"):
        bound_config({**config, "engine": "ode"})
    with pytest.raises(ValueError, match="host: must be one of"):
        bound_config({**config, "host": "spot"})


def test_mujoco_foot_forces_are_mj_contact_force_normals():
    """The fast read (constraint rows of elliptic cones) gives mj_contactForce's normal force per foot."""
    import mujoco

    cf = np.zeros(6)
    with make_world(WorldConfig(host="spined-dog", engine="mujoco")) as w:
        seen = 0
        for i in range(600):
            s = np.sin(i / 40)
            w.set_torques([s, 0.0, 0.0], {k: (0.0, 3 * s, -3 * s) for k in w.legs})
            w.step()
            ref = dict.fromkeys(w.legs, 0.0)
            for c in range(w.data.ncon):
                g1, g2 = w.data.contact.geom[c]
                key = w._geom_foot.get(g2 if g1 == w._floor else g1)
                if key is not None:
                    mujoco.mj_contactForce(w.model, w.data, c, cf)
                    ref[key] += cf[0]
                    seen += 1
            assert w.contact_force == pytest.approx(ref, abs=1e-12)
        assert seen > 100


RENDER = """
from sparc_quad.sim.quadruped_world import WorldConfig, make_world
with make_world(WorldConfig(host="spined-dog", engine="mujoco")) as w:
    try:
        img = w.render(96, 64)
    except Exception as exc:
        print("NO-GL", exc)
    else:
        print(img.shape, img.dtype, float(img.std()))
"""


def test_mujoco_renders_a_frame():
    """In a fresh process (MuJoCo picks its OpenGL backend at its first import: EGL when headless)."""
    import subprocess

    from tests.paths import ROOT

    out = subprocess.run([sys.executable, "-c", RENDER], cwd=ROOT, capture_output=True, text=True,
                         timeout=120, check=True).stdout.strip().splitlines()[-1]
    if out.startswith("NO-GL"):
        pytest.skip(f"MuJoCo cannot render here: {out}")
    shape, dtype, std = out.rsplit(" ", 2)
    assert shape == "(64, 96, 3)" and dtype == "uint8" and float(std) > 1.0
