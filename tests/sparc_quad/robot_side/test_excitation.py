"""The identification excitation (`bench-robot --experiment ident`) and hidden plant effects
(`bench-robot --effect`)."""

from __future__ import annotations

import argparse

import numpy as np
import pytest

from sparc_quad.cli.bench_robot import plant_with_effects
from sparc_quad.cli.errors import BadInput
from sparc_quad.robot_side.excitation import Excitation, ident_script
from spine_module import params as P


def test_target_stays_in_its_limits_and_its_derivatives_are_consistent():
    ex = Excitation()
    dur = 20.0
    t = np.arange(0.0, dur, 1e-3)
    x, dx, ddx = map(np.array, zip(*(ex.target(float(s), dur) for s in t), strict=True))
    off = np.abs(x - P.X_EQUILIBRIUM).max(axis=0)
    assert np.all(off <= np.array(ex.max_offset) + 1e-12) and np.all(off >= 0.5 * np.array(ex.max_offset))
    np.testing.assert_allclose(x[0], P.X_EQUILIBRIUM)
    np.testing.assert_allclose(x[-1], P.X_EQUILIBRIUM, atol=1e-6)
    np.testing.assert_allclose(np.gradient(x, 1e-3, axis=0)[5:-5], dx[5:-5], atol=2e-4 * np.abs(dx).max())
    np.testing.assert_allclose(np.gradient(dx, 1e-3, axis=0)[5:-5], ddx[5:-5], atol=2e-3 * np.abs(ddx).max())
    with pytest.raises(ValueError, match="too short"):
        ident_script(3.0)
    with pytest.raises(ValueError, match="beyond"):
        Excitation(max_offset=(0.1, 0.0, 0.0))


@pytest.mark.integration  # a whole simulated session, node and bench in process
def test_identification_run_moves_every_joint_within_its_limits():
    """In process (node and bench in lockstep): every joint reverses often, reaches speed, stays clear of
    its limits' damping margin, and the node reports no fault once running."""
    from sparc_quad.robot_side.bench import run_inprocess

    robot, states = run_inprocess(ident_script(8.0))
    q = np.array([s.q for s in states])[:, 1:]
    dq = np.array([s.dq for s in states])[:, 1:]
    lo = np.array([P.JOINT_LOWER_RAD[j] for j in P.ACTUATED_JOINTS]) + P.JOINT_LIMIT_MARGIN_RAD
    hi = np.array([P.JOINT_UPPER_RAD[j] for j in P.ACTUATED_JOINTS]) - P.JOINT_LIMIT_MARGIN_RAD
    assert np.all(q > lo) and np.all(q < hi)
    moving = dq[2000:-2000]
    reversals = np.sum(np.diff(np.sign(moving), axis=0) != 0, axis=0)
    assert np.all(reversals >= 10), reversals
    assert np.all(np.abs(moving).max(axis=0) > 0.3), np.abs(moving).max(axis=0)
    assert all(int(s.faults) == 0 for s in states[1000:])
    f = np.array(robot.log.f_cell)
    assert np.ptp(f) > 3.0  # the rig pushed and the load cell read it


def _args(*effects: str) -> argparse.Namespace:
    return argparse.Namespace(effect=list(effects), ideal_plant=False)


def test_effect_option_puts_the_effect_in_the_plant():
    from sparc_quad.sim.bench_world import BenchWorld

    cfg = plant_with_effects(_args("torque_gain:joint=q3,gain=0.5",
                                   "coulomb_friction:joint=q2,tau_c_nm=0.02"))
    named = {(e.name, e.joint): e.params for e in cfg.effects.effects}
    assert named == {("torque_gain", "q3"): {"gain": 0.5}, ("coulomb_friction", "q2"): {"tau_c_nm": 0.02}}
    assert cfg.effects.eps == pytest.approx(1.0 / cfg.friction.beta_s_rad)
    with BenchWorld(plant=cfg) as world:
        world.step(np.array([0.2, 0.4, 0.1]))
        np.testing.assert_allclose(world.last_applied, [0.2, 0.2, 0.1])
    assert plant_with_effects(_args()).effects is None


@pytest.mark.parametrize("spec, match", [
    ("torque_saturation:joint=q3", r"needs its value in N\*m"),
    ("payload_mass:joint=q3", "changes the rigid bodies"),
    ("nosuch:joint=q3", "unknown effect"),
    ("torque_gain:joint=q1", "not an actuated joint"),
    ("torque_gain:joint=q2,gain=x", "not a number"),
])
def test_effect_option_refuses_what_the_bench_cannot_carry(spec, match):
    with pytest.raises(BadInput, match=match):
        plant_with_effects(_args(spec))
