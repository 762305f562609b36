"""Gait C (the SPARC authors' speed-commanded Raibert bound) on their dog, through the one scenario: what it
resolves to, that it bounds forward in both engines, its rigid baseline is their locked model, and its held
steps are the full path's bit for bit."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from sparc_quad import Scenario, bound_config
from sparc_quad.bound.run import run_bound
from sparc_quad.gaits import authors_run as A
from sparc_quad.gaits.authors_raibert import LOCKED_SPINE_Q_RAD, AuthorsRaibertParams
from sparc_quad.scenario import ScenarioError, resolved

pytest.importorskip("mujoco")


def _run(s: Scenario, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        return run_bound(bound_config(s), **kw)


def test_resolves_to_their_run():
    """Their script's command, frequency, spine gains, later model and estimator are gait C's defaults."""
    r = resolved(Scenario(host="spined-dog", gait="authors-raibert"))
    assert (r.speed, r.frequency, r.step_height) == (1.3, 3.1, 0.08)
    assert (r.kx, r.kz, r.kth, r.dx, r.dz, r.dth) == (*A.RAIBERT_K, *A.RAIBERT_D)
    assert (r.joint_damping, r.joint_friction, r.spine_rate_hz) == (0.1, 0.1, 500.0)
    assert (r.base_motion, r.imu_noise, r.imu_delay) == ("authors-cvel", 0.0, 1)
    cfg = bound_config(Scenario(host="spined-dog", gait="authors-raibert", speed=0.9))
    assert isinstance(cfg.gait, AuthorsRaibertParams) and cfg.gait.speed_m_s == 0.9
    assert cfg.spine_schedule.x_d1_m == 0.367 and cfg.spine_schedule.theta_d_rad == -0.3
    assert cfg.world.joint_damping_nm_s_rad == 0.1 and cfg.world.joint_friction_nm == 0.1
    # the same keys elsewhere keep the frictionless model
    assert resolved(Scenario(host="spined-dog", gait="sine")).joint_damping == 0.0


@pytest.mark.parametrize("bad, key", [({"host": "solo12"}, "gait"), ({"step_length": 0.08}, "step_length"),
                                      ({"duty": 0.5}, "duty"), ({"spine": "rigid", "kx": 800.0}, "kx")])
def test_refuses_what_cannot_act(bad, key):
    """Keys of other gaits or spines, other robots: refused naming the key."""
    with pytest.raises(ScenarioError) as err:
        Scenario(**{"host": "spined-dog", "gait": "authors-raibert", **bad})
    assert err.value.key == key


@pytest.mark.parametrize("engine, speed", [("mujoco", 0.9), ("pybullet", 0.5)])
def test_bounds_forward_at_the_command(engine, speed):
    """4 s at the command: no fall, forward over the window. pybullet runs at 0.5 m/s, where it tracks
    (docs/bounding/authors-gait-c.md says where it does not)."""
    if engine == "pybullet":
        pytest.importorskip("pybullet")
    s = Scenario(host="spined-dog", gait="authors-raibert", engine=engine, speed=speed, duration=4.0)
    m = _run(s).metrics
    assert not m["fell"]
    assert 0.6 * speed < m["speed_m_s"] < 1.3 * speed
    assert m["target_speed_m_s"] == speed


def test_rigid_is_their_locked_model():
    """spine rigid: the three spine joints held at their locked model's (-0.85, 1.5, -0.85) throughout."""
    res = _run(Scenario(host="spined-dog", gait="authors-raibert", engine="mujoco", spine="rigid", speed=0.9,
                        duration=2.0))
    q = np.column_stack([res.column(c) for c in ("q2", "q3", "q4")])
    assert np.abs(q - np.array(LOCKED_SPINE_Q_RAD)).max() < 0.02
    assert not res.metrics["spine_actuated"]


def test_held_steps_bit_identical():
    cfg = bound_config(Scenario(host="spined-dog", gait="authors-raibert", engine="mujoco", speed=0.9,
                                duration=2.0, seed=2))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        held, full = run_bound(cfg, held_steps=True), run_bound(cfg, held_steps=False)
    assert held.metrics["held_steps"] > 0.3 * len(held.series)  # a call every 2 or 3 steps
    assert full.metrics["held_steps"] == 0
    assert held.series.tobytes() == full.series.tobytes()


def test_node_path_runs_their_target_on_the_dogs_spine_model():
    """Their target (x 0.367 m on their end effector) lies beyond the SPARC module's spine (0.361 m) but
    inside the dog's: the node judges commands by the spine model it runs, so gait C runs through it, every
    command accepted, in impedance mode, close to the direct path (quantised feedback, limits)."""
    from sparc_quad.scenario.resolve import spine_of
    from spine_module.messages import Mode
    from spine_module.workspace import SPARC

    s = Scenario(host="spined-dog", gait="authors-raibert", spine_path="node", engine="mujoco", duration=2.0,
                 seed=1)
    cfg = bound_config(s)
    assert SPARC.unreachable(cfg.spine_schedule.x_d1_m, cfg.spine_schedule.z_d_m, 0.0) is not None
    spine = spine_of(s, cfg)
    the_node = spine.node  # the spine drops it when the run closes it
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        node = run_bound(cfg, spine=spine)
    direct = _run(Scenario(host="spined-dog", gait="authors-raibert", engine="mujoco", duration=2.0, seed=1))
    assert the_node.rejected_count == 0, the_node.rejected
    modes = [st.mode for st in spine.states()]
    assert len(modes) > 1000 and set(modes[len(modes) // 10:]) == {Mode.IMPEDANCE}, set(modes)
    assert not node.metrics["fell"] and not direct.metrics["fell"]
    assert node.metrics["distance_m"] == pytest.approx(direct.metrics["distance_m"], abs=0.05)


def test_lcm_refused_for_the_dog_naming_it(capsys):
    """`spine-node` (another process) runs the SPARC module's spine model: the dog over --lcm is refused
    before anything is sent, not driven with the wrong links and masses."""
    from sparc_quad.cli import main
    from sparc_quad.robot_side.quad import NodeSpine

    assert main(["bound", "--host", "spined-dog", "--lcm", "--lcm-url", "memq://", "--wait-node", "0.1",
                 "--out", "/nonexistent-never-written"]) == 2
    err = capsys.readouterr().err
    assert "--lcm" in err and "spined-dog" in err and "Traceback" not in err
    cfg = bound_config(Scenario(host="spined-dog"))
    with pytest.raises(ValueError, match="SPARC module's spine"):  # the API refuses it too, before waiting
        NodeSpine.over_lcm(cfg.spine, url="memq://", wait_node_s=60.0, spine=cfg.spine_params)
