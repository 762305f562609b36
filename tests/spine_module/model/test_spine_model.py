"""The pinocchio model: URDF in sync with the parameters, RNEA-built M/C/g, Jacobian and J̇q̇."""

import numpy as np
import pinocchio as pin
import pytest

from sparc_quad.robots import spine_urdf_path
from sparc_quad.sim.robot_files import generate_all
from spine_module import params as P
from spine_module.model import SpineModel
from spine_module.urdf import spine_urdf


@pytest.fixture(scope="module")
def model() -> SpineModel:
    return SpineModel()


def random_states(n: int, seed: int = 0):
    rng = np.random.default_rng(seed)
    for _ in range(n):
        q = P.Q_EQUILIBRIUM + rng.uniform(-0.5, 0.5, 4)
        q[0] = rng.uniform(-0.6, 0.6)  # torso pitch
        yield q, rng.normal(0, 2.0, 4), rng.normal(0, 5.0, 4)


def test_committed_urdfs_match_generators():
    for path, text in generate_all().items():
        assert path.read_text() == text, f"{path} drifted: run `sparc-quad robots generate`"


def test_urdf_carries_table_iii(model):
    masses = [model.model.inertias[i].mass for i in range(1, 5)]
    assert masses == pytest.approx([0.377, 0.376, 0.414, 0.060])
    assert model.model.inertias[3].inertia[1, 1] == pytest.approx(175e-6)
    assert list(model.model.effortLimit[1:]) == [12.0, 12.0, 12.0]
    assert spine_urdf_path().read_text() == spine_urdf()


def test_equilibrium_pose_is_papers_x_d(model):
    assert model.task_pose(P.Q_EQUILIBRIUM) == pytest.approx(P.X_EQUILIBRIUM, abs=1e-12)
    straight = model.task_pose(np.zeros(4))
    assert straight[0] == pytest.approx(0.3614)


def test_task_pose_is_relative_to_hind_body(model):
    q = P.Q_EQUILIBRIUM + np.array([0.0, 0.1, -0.2, 0.05])
    q_tilted = q.copy()
    q_tilted[0] = 0.4
    assert model.task_pose(q_tilted) == pytest.approx(model.task_pose(q), abs=1e-14)


@pytest.mark.parametrize("seed", [0, 1])
def test_mass_matrix_bias_gravity_from_rnea_match_crba_nle(model, seed):
    data = model.create_data()
    ref = model.model.createData()
    for q, dq, _ in random_states(10, seed):
        M = model.mass_matrix(data, q)
        np.testing.assert_allclose(M, pin.crba(model.model, ref, q), atol=1e-9)
        np.testing.assert_allclose(model.bias(data, q, dq), pin.nonLinearEffects(model.model, ref, q, dq),
                                   atol=1e-9)
        np.testing.assert_allclose(model.gravity(data, q), pin.computeGeneralizedGravity(model.model, ref, q),
                                   atol=1e-9)


def test_gravity_depends_on_torso_pitch(model):
    data = model.create_data()
    q = P.Q_EQUILIBRIUM.copy()
    g0 = model.gravity(data, q)
    q[0] = 0.5
    assert not np.allclose(model.gravity(data, q), g0, atol=1e-3)


def test_jacobian_matches_finite_differences(model):
    data = model.create_data()
    h = 1e-7
    for q, _, _ in random_states(5, 2):
        model.update_kinematics(data, q, np.zeros(4))
        J = data.J.copy()
        for i in range(4):
            e = np.zeros(4)
            e[i] = h
            fd = (model.task_pose(q + e) - model.task_pose(q - e)) / (2 * h)
            np.testing.assert_allclose(J[:, i], fd, atol=1e-7)
        assert np.all(J[:, 0] == 0.0)


def test_jdot_qdot_matches_finite_differences(model):
    data = model.create_data()
    h = 1e-6
    for q, dq, _ in random_states(5, 3):
        model.update_kinematics(data, q, dq)
        jdqd = data.jdot_qdot.copy()
        # d/dt (J(q) dq) at constant dq = J̇ dq
        Jp = model.task_jacobian(q + h * dq)
        Jm = model.task_jacobian(q - h * dq)
        np.testing.assert_allclose(jdqd, (Jp - Jm) @ dq / (2 * h), atol=1e-6)


def test_inverse_kinematics_round_trip(model):
    x = P.X_EQUILIBRIUM + np.array([0.03, -0.01, 0.05])
    q = model.inverse_kinematics(x)
    assert model.task_pose(q) == pytest.approx(x, abs=1e-10)


def test_effective_mass_includes_rotor_inertia():
    with_rotor = SpineModel().effective_mass_x(P.Q_EQUILIBRIUM)
    links_only = SpineModel(P.SpineParams(armature_kg_m2=0.0)).effective_mass_x(P.Q_EQUILIBRIUM)
    assert with_rotor > links_only > 0.3
