"""`gap synth --arm`: the synthetic 6-DoF arm obeys its own dynamics, read back through the project's reader.

The check is independent of the simulator's code path: pinocchio's RNEA on the link-scaled URDF model plus
the named hidden effects (truth.json) applied to the written states must reproduce the written (measured)
torque to the current-noise level, and the URDF alone must not."""

from __future__ import annotations

import json
import logging

import numpy as np
import pinocchio as pin
import pytest

from sparc_quad.cli import main as cli_main
from sparc_quad.effects import Effect, PlantEffects
from sparc_quad.gap import synth_arm as sa
from sparc_quad.gap.robot import Robot
from sparc_quad.gap.trial import load_trial


def noise_floor_nm(truth: dict) -> np.ndarray:
    """1-sigma joint-side torque noise: T^T (kt * sigma_i), summed in quadrature over motors."""
    case = truth["case"]
    T = np.array(truth["transmission_q_motor_from_q_joint"])
    kt = np.array(case["torque_constants_nm_per_a"])
    return np.sqrt(((T * (kt * case["current_noise_a"])[:, None]) ** 2).sum(0))


def residuals(trial, truth: dict) -> tuple[np.ndarray, np.ndarray]:
    """(rms of measured - [RNEA(true links) + effects], rms of measured - RNEA(URDF)) per joint."""
    dt = trial.dt
    ddq = np.diff(trial.dq, axis=0) / dt  # semi-implicit Euler: dq[k+1] = dq[k] + dt ddq[k]
    q, dq, tau = trial.q[:-1], trial.dq[:-1], trial.tau_meas[:-1]
    model = sa.link_scaled_model(trial.robot, truth)
    pred = Robot.rnea(model, q, dq, ddq) + sa.joint_effect_torque(truth, q, dq, ddq, dt)
    nominal = Robot.rnea(trial.robot.model, q, dq, ddq)
    return np.sqrt(np.mean((tau - pred) ** 2, 0)), np.sqrt(np.mean((tau - nominal) ** 2, 0))


@pytest.fixture(scope="module")
def motor_side_case(tmp_path_factory):
    out = tmp_path_factory.mktemp("arm")
    res = sa.synth_arm(out, seed=3, n_trials=2, periods=1, period_s=0.6)
    return res


def test_motor_side_log_obeys_its_own_dynamics(motor_side_case):
    truth = motor_side_case["truth"]
    floor = noise_floor_nm(truth)
    for path in motor_side_case["trials"]:
        trial = load_trial(path)  # motor side: transmission, torque constants (A -> N*m), coupled wrist
        assert trial.torque_kind == "measured" and trial.meta.get("transmission_applied")
        res, nominal = residuals(trial, truth)
        assert np.all(res < 1.15 * floor) and np.all(res > 0.85 * floor), (res, floor)
        assert np.all(nominal[:3] > 10 * floor[:3]), nominal  # the hidden effects are not small


def test_true_plant_file_is_the_truth(motor_side_case):
    """true_plant.json through the plant-effects library (link_inertia, armature, coupled inertia and
    friction) reproduces the logged torque to the noise floor, like truth.json does."""
    pe = PlantEffects.load(motor_side_case["true_plant"])
    floor = noise_floor_nm(motor_side_case["truth"])
    trial = load_trial(motor_side_case["trials"][0])
    dt = trial.dt
    ddq = np.diff(trial.dq, axis=0) / dt
    q, dq, tau = trial.q[:-1], trial.dq[:-1], trial.tau_meas[:-1]
    model = pe.apply_to_pinocchio(trial.robot.model)  # link errors + diagonal rotor inertia
    # friction at the midpoint velocity dq + dt ddq / 2 (the simulator linearises it; exact here)
    pred = (Robot.rnea(model, q, dq, ddq) + pe.coupled_inertia_torque(ddq)
            - pe.friction_torque(dq + 0.5 * dt * ddq))
    rms = np.sqrt(np.mean((tau - pred) ** 2, 0))
    assert np.all(rms < 1.3 * floor), (rms, floor)


def test_case_is_what_the_issue_asks_for(motor_side_case, caplog):
    truth = motor_side_case["truth"]
    hidden = truth["hidden"]
    names = {(e["name"], e.get("joint")) for e in hidden}
    for j in sa.JOINTS[:5]:
        for n in ("coulomb_friction", "viscous_friction", "rotor_inertia"):
            assert (n, j) in names
    coupling = [e for e in hidden if e["name"].startswith("coupled_")]
    assert len(coupling) == 3 and all(e["params"]["direction"] == [0, 0, 0, 0, 1, 1] for e in coupling)
    scales = [e["params"]["scale"] for e in hidden if e["name"] == "link_inertia_error"]
    assert len(scales) == 5 and all(0.0999 <= abs(s - 1) <= 0.3001 for s in scales)
    assert max(e["params"].get("tau_c_nm", 0) for e in hidden) >= 5.0  # several N m on the big joints
    path = motor_side_case["trials"][0]
    meta = json.loads(path.with_suffix(".json").read_text())
    assert meta["rate_hz"] == 5000.0 and meta["torque_kind"] == "measured"
    with caplog.at_level(logging.WARNING):
        robot = Robot(motor_side_case["urdf"], sa.JOINTS, {}, (0, 0, -9.81))
    M = pin.crba(robot.model, robot.model.createData(), np.full(6, 0.3))
    assert np.allclose(M[5], 0.0)  # the flange is massless: the URDF's mass matrix is singular


def test_uncoupled_joint_side_effects_are_the_libraries(tmp_path):
    """With an uncoupled wrist, every motor's effects are the plant-effects library's coulomb_friction,
    viscous_friction and rotor_inertia on its joint: the written torque is RNEA + armature ddq - friction."""
    case = sa.ArmCase(coupled_wrist=False)
    res = sa.synth_arm(tmp_path, seed=5, n_trials=1, periods=1, period_s=0.5, case=case, motor_side=False)
    trial = load_trial(res["trials"][0])
    assert "transmission" not in trial.meta
    truth = res["truth"]
    effects = [Effect(e["name"], e["joint"], e["params"]) for e in truth["hidden"]
               if e["name"] in ("coulomb_friction", "viscous_friction", "rotor_inertia")]
    assert len(effects) == 18
    pe = PlantEffects(sa.JOINTS, effects, truth["friction_smoothing_rad_s"])
    dt = trial.dt
    ddq = np.diff(trial.dq, axis=0) / dt
    q, dq, tau = trial.q[:-1], trial.dq[:-1], trial.tau_meas[:-1]
    fric = np.array([pe.friction_torque(v) for v in dq])
    slope = np.array([pe.friction_slope(v) for v in dq])  # -d friction / d dq
    # friction at the step's linearised midpoint velocity: f(dq) - slope * (dt ddq) / 2
    pred = (Robot.rnea(sa.link_scaled_model(trial.robot, truth), q, dq, ddq) + pe.armature() * ddq
            - (fric - 0.5 * dt * slope * ddq))
    rms = np.sqrt(np.mean((tau - pred) ** 2, 0))
    floor = noise_floor_nm(truth)
    assert np.all(rms < 1.15 * floor), (rms, floor)


def test_cli_synth_arm(tmp_path, capsys):
    out = tmp_path / "arm"
    assert cli_main(["gap", "synth", "--arm", "--out", str(out), "--trials-n", "1", "--periods", "1",
                     "--period", "0.1", "--no-dq"]) == 0
    trial = load_trial(out / "arm_00.csv")  # no dq columns: the reader differentiates q
    assert trial.meta.get("dq_source") and len(trial.t) == 500
    assert (out / "truth.json").exists()
    try:  # refused while parsing (SystemExit) or by the generator (return code): exit 2 either way
        code = cli_main(["gap", "synth", "--arm", "--out", str(tmp_path / "bad"), "--period", "0"])
    except SystemExit as exc:
        code = exc.code
    assert code == 2
    assert "period" in capsys.readouterr().err
    assert not (tmp_path / "bad").exists()


@pytest.mark.slow
def test_default_case_45k_samples(tmp_path):
    """The default case: 3 trials x 2 periods x 1.5 s at 5 kHz = 45 000 samples x 6 joints."""
    res = sa.synth_arm(tmp_path, seed=0)
    trials = [load_trial(p) for p in res["trials"]]
    assert sum(len(tr.t) for tr in trials) == 45000
    floor = noise_floor_nm(res["truth"])
    for tr in trials:
        rms, nominal = residuals(tr, res["truth"])
        assert np.all(rms < 1.15 * floor) and np.all(nominal[:3] > 10 * floor[:3])
