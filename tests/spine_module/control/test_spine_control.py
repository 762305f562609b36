"""Controllers of eq. 3, 4, 5: the laws themselves, saturation, bad input, run-time changes."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from spine_module import params as P
from spine_module.control import ImpedanceController, StribeckFriction, TaskPDController
from spine_module.model import SpineModel

MODEL = SpineModel()


def test_impedance_at_rest_on_target_is_gravity_compensation():
    ctrl = ImpedanceController(MODEL)
    for q1 in (0.0, 0.4, -0.3):
        q = P.Q_EQUILIBRIUM.copy()
        q[0] = q1
        out = ctrl.step(q, np.zeros(4))
        assert out.ok
        np.testing.assert_allclose(out.tau, MODEL.gravity(MODEL.create_data(), q)[1:], atol=1e-9)


def test_impedance_equals_explicit_eq3():
    """The one-RNEA-pass form equals M J†(ẍ_d − J̇q̇) + Jᵀ(D ė + K e) + C q̇ + g built term by term."""
    rng = np.random.default_rng(4)
    ctrl = ImpedanceController(MODEL, friction=None, k=(400, 900, 12), d=(10, 15, 0.2), dls_lambda=1e-3)
    ctrl.set_target(x_d=(0.28, 0.01, 0.05), dx_d=(0.1, 0.0, 0.2), ddx_d=(1.0, -0.5, 2.0))
    data = MODEL.create_data()
    for _ in range(5):
        q = P.Q_EQUILIBRIUM + rng.uniform(-0.2, 0.2, 4)
        dq = rng.normal(0, 1, 4)
        ddq1 = rng.normal()
        out = ctrl.step(q, dq, ddq1)
        MODEL.update_kinematics(data, q, dq)
        J = data.J
        Jpinv = J.T @ np.linalg.inv(J @ J.T + 1e-6 * np.eye(3))
        a = Jpinv @ (ctrl.ddx_d - data.jdot_qdot)
        a[0] = ddq1
        e = ctrl.x_d - data.x
        de = ctrl.dx_d - data.dx
        tau = MODEL.mass_matrix(data, q) @ a + J.T @ (ctrl.D * de + ctrl.K * e) + MODEL.bias(data, q, dq)
        np.testing.assert_allclose(out.tau_raw, tau[1:], atol=1e-9)


def test_pd_is_jacobian_transpose_spring_damper():
    ctrl = TaskPDController(MODEL, k=(500, 1000, 15), d=(5, 5, 0.1))
    q = MODEL.inverse_kinematics(P.X_EQUILIBRIUM + np.array([0.01, 0.0, 0.0]))
    out = ctrl.step(q, np.zeros(4))
    J = MODEL.task_jacobian(q)
    np.testing.assert_allclose(out.tau, J[:, 1:].T @ np.array([-5.0, 0, 0]), atol=1e-9)


def test_saturation_clamps_and_flags():
    ctrl = ImpedanceController(MODEL, k=(1e6, 1e6, 1e4), d=(0, 0, 0))
    ctrl.set_target(x_d=(0.33, 0.05, 0.3))
    out = ctrl.step(P.Q_EQUILIBRIUM, np.zeros(4))
    assert out.ok and out.saturated.any()
    assert np.all(np.abs(out.tau) <= 12.0)
    assert np.all(np.abs(out.tau_raw[out.saturated]) > 12.0)


@pytest.mark.parametrize("bad", ["q", "dq", "ddq1"])
@pytest.mark.parametrize("value", [np.nan, np.inf, -np.inf])
def test_non_finite_input_gives_zero_torque_and_names_field(bad, value):
    for ctrl in (ImpedanceController(MODEL, StribeckFriction.nominal()), TaskPDController(MODEL)):
        q, dq, ddq1 = P.Q_EQUILIBRIUM.copy(), np.zeros(4), 0.0
        if bad == "q":
            q[2] = value
        elif bad == "dq":
            dq[3] = value
        else:
            ddq1 = value
        out = ctrl.step(q, dq, ddq1)
        if bad == "ddq1" and isinstance(ctrl, TaskPDController):
            continue
        assert not out.ok and bad in out.error
        assert np.all(out.tau == 0.0)
        # recovers on the next good sample
        assert ctrl.step(P.Q_EQUILIBRIUM, np.zeros(4)).ok


def test_wrong_shape_is_an_error_not_an_exception():
    out = ImpedanceController(MODEL).step(np.zeros(3), np.zeros(3))
    assert not out.ok and "4 joints" in out.error


def test_gains_and_target_change_at_run_time_and_are_validated():
    ctrl = ImpedanceController(MODEL)
    q = MODEL.inverse_kinematics(P.X_EQUILIBRIUM + np.array([0.01, 0, 0]))
    t1 = ctrl.step(q, np.zeros(4)).tau.copy()
    ctrl.set_gains(k=(2 * P.K_DEFAULT[0], P.K_DEFAULT[1], P.K_DEFAULT[2]))
    t2 = ctrl.step(q, np.zeros(4)).tau.copy()
    g = MODEL.gravity(MODEL.create_data(), q)[1:]
    np.testing.assert_allclose(t2 - g, 2 * (t1 - g), atol=1e-9)
    with pytest.raises(ValueError, match="K"):
        ctrl.set_gains(k=(-1, 0, 0))
    with pytest.raises(ValueError, match="x_d"):
        ctrl.set_target(x_d=(np.nan, 0, 0))


def test_output_buffer_is_reused():
    ctrl = ImpedanceController(MODEL)
    a = ctrl.step(P.Q_EQUILIBRIUM, np.zeros(4))
    b = ctrl.step(P.Q_EQUILIBRIUM, np.zeros(4))
    assert a is b and a.tau is b.tau


@settings(max_examples=200, deadline=None)
@given(st.lists(st.floats(-0.6, 0.6), min_size=3, max_size=3))
def test_dls_pseudo_inverse_is_a_right_inverse_away_from_singularities(dq_act):
    q = P.Q_EQUILIBRIUM.copy()
    q[1:] += np.array(dq_act)
    J = MODEL.task_jacobian(q)[:, 1:]
    if np.linalg.svd(J, compute_uv=False)[-1] < 0.02:
        return  # near the straight (singular) spine the damping is meant to bite
    lam2 = P.DLS_LAMBDA**2
    Jpinv = J.T @ np.linalg.inv(J @ J.T + lam2 * np.eye(3))
    np.testing.assert_allclose(J @ Jpinv, np.eye(3), atol=5e-3)


@settings(max_examples=100, deadline=None)
@given(st.floats(-20, 20, allow_nan=False))
def test_stribeck_friction_shape(v):
    f = StribeckFriction.nominal(1)
    p = P.NOMINAL_FRICTION
    tau = float(f.torque(np.array([v]))[0])
    assert float(f.torque(np.array([-v]))[0]) == pytest.approx(-tau, abs=1e-12)  # odd
    assert abs(tau) <= p.tau_s_nm + p.b_nm_s_rad * abs(v) + 1e-12  # bounded by breakaway + viscous
    if abs(v) > 2.0:  # Coulomb + viscous far from zero velocity
        assert tau == pytest.approx(np.sign(v) * p.tau_c_nm + p.b_nm_s_rad * v, rel=1e-6)
    h = 1e-7
    fd = (f.torque(np.array([v + h]))[0] - f.torque(np.array([v - h]))[0]) / (2 * h)
    if abs(v) > 1e-3:
        assert float(f.slope(np.array([v]))[0]) == pytest.approx(fd, rel=1e-4, abs=1e-6)


def test_friction_compensation_adds_eq4_torque():
    fr = StribeckFriction.nominal()
    with_f = ImpedanceController(MODEL, friction=fr)
    without = ImpedanceController(MODEL, friction=None)
    dq = np.array([0.0, 0.3, -0.2, 0.05])
    diff = with_f.step(P.Q_EQUILIBRIUM, dq).tau - without.step(P.Q_EQUILIBRIUM, dq).tau
    np.testing.assert_allclose(diff, fr.torque(dq[1:]), atol=1e-12)
