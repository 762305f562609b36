"""Reduced-size runs of the paper's three bench experiments, asserting the paper's criteria."""

from dataclasses import replace

import numpy as np
import pybullet as p
import pytest

from sparc_quad.experiments import dynamic, pd, static
from sparc_quad.sim.bench_world import BenchWorld
from sparc_quad.sim.plant import PlantConfig
from spine_module import params as P
from spine_module.model import SpineModel


def test_bench_plant_dynamics_agree_with_pybullet():
    """The plant's pinocchio M and h (used for rotor inertia and friction) are pybullet's own."""
    model = SpineModel(P.SpineParams(armature_kg_m2=0.0))
    data = model.create_data()
    q = P.Q_EQUILIBRIUM + np.array([0.0, 0.1, -0.2, 0.3])
    dq = np.array([0.0, 0.5, -1.0, 2.0])
    with BenchWorld() as w:
        M_pb = np.array(p.calculateMassMatrix(w.body, q.tolist(), physicsClientId=w.client))
        h_pb = np.array(p.calculateInverseDynamics(w.body, q.tolist(), dq.tolist(), [0.0] * 4,
                                                   physicsClientId=w.client))
    np.testing.assert_allclose(M_pb, model.mass_matrix(data, q), atol=1e-9)
    np.testing.assert_allclose(h_pb, model.bias(data, q, dq), atol=1e-9)


def test_plant_is_deterministic_for_a_seed():
    cfg = static.StaticConfig(k_values=(500.0,), period_s=1.0, cycles=1)
    a = static.measure_stiffness(500.0, cfg)[2]
    b = static.measure_stiffness(500.0, cfg)[2]
    c = static.measure_stiffness(500.0, cfg, seed=7)[2]
    np.testing.assert_array_equal(a, b)
    assert not np.array_equal(a, c)


@pytest.fixture(scope="module")
def static_rows():
    cfg = static.StaticConfig(k_values=(300.0, 500.0, 700.0), period_s=8.0, cycles=1, sample_every=5)
    return static.run_static(cfg)[0]


def test_static_stiffness_within_paper_criterion(static_rows):
    for row in static_rows:
        assert row.n > 1000
        assert row.rel_err_pct <= 1.5, row
        assert row.r2 >= 0.99, row
        assert row.ci95_low < row.k_hat < row.ci95_high


def test_static_detects_a_wrong_stiffness():
    """The criterion can fail: a plant with 3x the friction and no compensation misses it."""
    plant = replace(PlantConfig(), friction=P.NOMINAL_FRICTION.scaled(3.0, 3.0, 3.0))
    cfg = static.StaticConfig(k_values=(300.0,), period_s=4.0, cycles=1, plant=plant, controller="pd")
    row = static.measure_stiffness(300.0, cfg)[0]
    assert row.rel_err_pct > 1.5 or row.r2 < 0.99


@pytest.fixture(scope="module")
def dynamic_cases():
    cfg = dynamic.DynamicConfig(k_values=(300.0, 500.0), trials=2, duration_s=1.5)
    return {(c.k, c.b): c for c in dynamic.run_dynamic(cfg)[0]}


def test_dynamic_high_damping_follows_ideal(dynamic_cases):
    for k in (300.0, 500.0):
        for b in (20.0, 40.0):
            assert dynamic_cases[(k, b)].nrmse < 0.03, dynamic_cases[(k, b)]


def test_dynamic_undamped_grows_with_overcompensated_friction(dynamic_cases):
    for k in (300.0, 500.0):
        assert dynamic_cases[(k, 0.0)].amplitude_growth > 1.1


def test_dynamic_light_damping_drifts_in_phase_as_it_decays(dynamic_cases):
    for k in (300.0, 500.0):
        assert dynamic_cases[(k, 2.0)].amplitude_growth < 0.8  # decays
    drift = [abs(dynamic_cases[(k, 2.0)].phase_drift_rad) for k in (300.0, 500.0)]
    assert max(drift) > 0.1  # and slips out of phase with the ideal as it does


def test_dynamic_friction_mismatch_shows_in_the_decay_rate():
    """With the plant equal to the model the fitted damping ratio is the commanded one; the
    over-compensating friction estimate removes damping at low speed, so the fitted ratio drops."""
    cfg = dynamic.DynamicConfig(k_values=(300.0,), b_values=(2.0,), trials=1, duration_s=1.0)
    real = dynamic.run_dynamic(cfg)[0][0]
    ideal = dynamic.run_dynamic(replace(cfg, plant=PlantConfig().ideal()))[0][0]
    assert ideal.zeta_fit == pytest.approx(ideal.zeta_ideal, rel=0.2)  # d_z, d_theta damp the mode too
    assert real.zeta_fit < 0.75 * real.zeta_ideal


def test_pd_slopes_rise_with_k_and_miss_more_than_impedance():
    cfg = pd.PDConfig(k_values=(300.0, 600.0), trials=2, displacements_m=(0.01, 0.02, 0.03))
    rows = {(r.controller, r.k_cmd): r for r in pd.run_pd(cfg)}
    assert rows[("pd", 600.0)].slope_mean > rows[("pd", 300.0)].slope_mean + 200
    for k in (300.0, 600.0):
        pd_err = abs(rows[("pd", k)].slope_mean - k)
        imp_err = abs(rows[("impedance", k)].slope_mean - k)
        assert pd_err > 2 * imp_err
