"""The plant-effects file and its simulation hooks."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from sparc_quad.effects import Effect, PlantEffects, PlantEffectsError, names
from sparc_quad.gap.robot import Robot
from sparc_quad.gap.synth import SPINE_URDF

J = ["q2", "q3", "q4"]


def test_names():
    assert names() == ("coulomb_friction", "viscous_friction", "stribeck_friction", "rotor_inertia",
                       "torque_gain", "torque_offset", "time_delay", "link_inertia", "payload_mass",
                       "encoder_offset", "torque_saturation", "torque_deadband", "asymmetric_coulomb",
                       "coupled_rotor_inertia", "coupled_coulomb_friction", "coupled_viscous_friction")


def test_asymmetric_and_coupled_friction():
    u = [0.0, 1.0, 1.0]  # one motor on q3 + q4
    pe = PlantEffects(J, [Effect("coulomb_friction", "q2", {"tau_c_nm": 0.5}),
                          Effect("asymmetric_coulomb", "q2", {"delta_nm": 0.1}),
                          Effect("coupled_coulomb_friction", "q4", {"direction": u, "tau_c_nm": 0.2}),
                          Effect("coupled_viscous_friction", "q4", {"direction": u, "b_nm_s_rad": 0.3}),
                          Effect("coupled_rotor_inertia", "q4", {"direction": u, "inertia_kg_m2": 0.01})],
                      1e-4)
    up = pe.friction_torque(np.array([1.0, 0.0, 0.0]))
    down = pe.friction_torque(np.array([-1.0, 0.0, 0.0]))
    assert up[0] == pytest.approx(-0.6) and down[0] == pytest.approx(0.4)  # 0.5 +- 0.1 by direction
    f = pe.friction_torque(np.array([0.0, 0.5, -0.2]))  # s = 0.3
    assert f[1] == pytest.approx(-(0.2 + 0.3 * 0.3)) and f[2] == pytest.approx(f[1])
    f0 = pe.friction_torque(np.array([0.0, 0.5, -0.5]))  # the motor stands still: no coupled friction
    assert f0[1] == pytest.approx(0.0, abs=1e-9)
    np.testing.assert_allclose(pe.coupled_inertia_torque(np.array([0.0, 2.0, 1.0])), [0.0, 0.03, 0.03])
    h = 1e-7
    dq = np.array([0.3, 0.2, 0.1])
    for i in range(3):  # slope = diagonal of -d friction / d dq
        e = np.zeros(3)
        e[i] = h
        num = -(pe.friction_torque(dq + e)[i] - pe.friction_torque(dq - e)[i]) / (2 * h)
        assert pe.friction_slope(dq)[i] == pytest.approx(num, rel=1e-5)
    with pytest.raises(PlantEffectsError, match="direction"):
        PlantEffects(J, [Effect("coupled_rotor_inertia", "q4", {"direction": [1, 1], "inertia_kg_m2": 1})])


def test_round_trip(tmp_path):
    pe = PlantEffects(J, [Effect("coulomb_friction", "q3", {"tau_c_nm": 0.1}),
                          Effect("payload_mass", "q3", {"mass_kg": 0.2, "xyz_m": [0.1, 0, 0]},
                                 "front_spine")])
    pe.save(tmp_path / "p.json")
    back = PlantEffects.load(tmp_path / "p.json")
    assert back.to_dict() == pe.to_dict()
    with pytest.raises(PlantEffectsError):
        PlantEffects.from_dict({"schema": "x"})
    with pytest.raises(PlantEffectsError):
        PlantEffects(J, [Effect("coulomb_friction", "q9", {"tau_c_nm": 0.1})])


def test_actuator_chain_and_delay():
    pe = PlantEffects(J, [Effect("time_delay", "q2", {"delay_s": 0.002}),
                          Effect("torque_deadband", "q3", {"width_nm": 0.1}),
                          Effect("torque_gain", "q3", {"gain": 0.5}),
                          Effect("torque_offset", "q4", {"offset_nm": 0.05}),
                          Effect("torque_saturation", "q4", {"limit_nm": 1.0})])
    pe.reset(0.001)
    outs = [pe.applied_torque(np.array([k + 1.0, 0.3, 2.0])) for k in range(4)]
    assert [o[0] for o in outs] == [0.0, 0.0, 1.0, 2.0]
    assert outs[0][1] == pytest.approx(0.5 * 0.2) and outs[0][2] == 1.0
    series = pe.applied_torque_series(np.array([[k + 1.0, 0.3, 2.0] for k in range(4)]), 0.001)
    np.testing.assert_allclose(series, np.array(outs))


def test_friction_terms_add_up():
    pe = PlantEffects(J, [Effect("stribeck_friction", "q3", {"tau_s_nm": 0.1, "dq_s_rad_s": 0.05}),
                          Effect("stribeck_friction", "q3", {"tau_s_nm": 0.2, "dq_s_rad_s": 0.5}),
                          Effect("coulomb_friction", "q3", {"tau_c_nm": 0.05}),
                          Effect("viscous_friction", "q3", {"b_nm_s_rad": 0.1})], 0.01)
    dq = np.array([0.0, 0.3, 0.0])
    want = -(0.05 + 0.1 * np.exp(-36) + 0.2 * np.exp(-0.36)) * np.tanh(30) - 0.03
    assert pe.friction_torque(dq)[1] == pytest.approx(want)
    assert pe.friction_torque(-dq)[1] == pytest.approx(-want)


def test_pinocchio_armature_and_payload():
    rb = Robot(SPINE_URDF, J, {"q1": 0.0})
    pe = PlantEffects(J, [Effect("rotor_inertia", "q3", {"inertia_kg_m2": 1e-3}),
                          Effect("payload_mass", "q4", {"mass_kg": 0.1, "xyz_m": [0.05, 0, 0]}),
                          Effect("encoder_offset", "q2", {"offset_rad": 0.01})])
    m = pe.apply_to_pinocchio(rb.model)
    q = np.array([-0.9, 1.8, -0.9])
    M0 = pin.crba(rb.model, rb.model.createData(), q)
    M1 = pin.crba(m, m.createData(), q)
    assert M1[1, 1] - M0[1, 1] > 1e-3 - 1e-12
    assert m.inertias[3].mass == pytest.approx(0.16)
    assert pe.measured_q(np.zeros(3))[0] == 0.01
    assert rb.model.inertias[3].mass == pytest.approx(0.06)  # the original is untouched


def test_external_wrench_torque_matches_virtual_work():
    rb = Robot(SPINE_URDF, J, {"q1": 0.0}, ee_frame="end_effector")
    q = np.array([[-0.9, 1.8, -0.9]])
    w = np.array([[1.5, -2.0, 0.1]])  # f_x, f_z, m_y in the base frame
    tau = rb.ext_torque(q, w)[0]
    data = rb.model.createData()
    fid = rb.model.getFrameId("end_effector")

    def pose(qq):
        pin.framesForwardKinematics(rb.model, data, qq)
        M = data.oMf[fid]
        return np.array([M.translation[0], M.translation[2], np.arctan2(M.rotation[0, 2], M.rotation[0, 0])])

    h = 1e-6
    for i in range(3):
        dq = np.zeros(3)
        dq[i] = h
        dp = (pose(q[0] + dq) - pose(q[0] - dq)) / (2 * h)
        assert tau[i] == pytest.approx(dp @ w[0], abs=1e-6)
