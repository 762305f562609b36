"""The real Stäubli TX40 log (tests/data/staubli_tx40): the committed trials are what the importer makes from
the published source, and the published transmission, offsets and URDF agree with the measured torques."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
from scipy import signal

from sparc_quad.gap import import_tx40 as im
from sparc_quad.gap.robot import Robot
from sparc_quad.gap.trial import load_trial
from tests.paths import DATA as TEST_DATA

DATA = TEST_DATA / "staubli_tx40"
URDF = DATA / im.URDF_NAME
WINDOWS = ((0.0, 4.0), (4.0, 8.0))  # what tests/data/staubli_tx40/README.md says tx40_00/tx40_01 are


def load_motor_trial(csv: Path) -> tuple[dict, np.ndarray, np.ndarray, np.ndarray]:
    """The CSV as written (motor side): (sidecar, t, q_motor, tau_motor)."""
    meta = json.loads(csv.with_suffix(".json").read_text())
    arr = np.loadtxt(csv, delimiter=",", skiprows=1)
    return meta, arr[:, 0], arr[:, 1:7], arr[:, 7:13]


def joint_fit(trial, cutoff_hz: float = 20.0):
    """Per joint: least squares of the measured joint torque on [rnea(URDF), sign(dq), dq, ddq, 1] over
    moving samples. Returns (coefficients (6, 5), residual rms, filtered torque)."""
    rate_hz = trial.rate_hz
    b, a = signal.butter(4, cutoff_hz / (rate_hz / 2))
    qf, tf = signal.filtfilt(b, a, trial.q, axis=0), signal.filtfilt(b, a, trial.tau_meas, axis=0)
    dq = np.gradient(qf, 1 / rate_hz, axis=0)
    ddq = np.gradient(dq, 1 / rate_hz, axis=0)
    step = max(1, round(rate_hz / 200))  # 200 Hz is plenty below the 20 Hz cut-off
    rnea = Robot.rnea(trial.robot.model, qf[::step], dq[::step], ddq[::step])
    tf, dq, ddq = tf[::step], dq[::step], ddq[::step]
    coef, res = np.zeros((6, 5)), np.zeros(6)
    for j in range(6):
        moving = np.abs(dq[:, j]) > 0.05
        A = np.column_stack([rnea[:, j], np.sign(dq[:, j]), dq[:, j], ddq[:, j], np.ones(len(dq))])[moving]
        coef[j], *_ = np.linalg.lstsq(A, tf[moving, j], rcond=None)
        res[j] = np.sqrt(np.mean((tf[moving, j] - A @ coef[j]) ** 2))
    return coef, res, tf


def test_committed_trials_are_the_importers_output(tmp_path):
    paths = im.convert(DATA / "source", tmp_path, WINDOWS, factor=5, urdf=URDF)
    for made in paths:
        committed = DATA / made.name
        m_meta, *m_arr = load_motor_trial(made)
        c_meta, *c_arr = load_motor_trial(committed)
        for x, y in zip(m_arr, c_arr, strict=True):
            np.testing.assert_allclose(x, y, rtol=1e-7, atol=1e-12)
        assert c_meta["urdf"] == im.URDF_NAME and (committed.parent / c_meta["urdf"]).exists()
        m_meta.pop("urdf")
        c_meta.pop("urdf")
        assert m_meta == c_meta


def test_reader_maps_motors_to_joints_with_the_coupled_wrist():
    """Through the project's reader: at rest at the start the joints are at the URDF's zero (home pose)
    and joint 5's torque carries motor 6's (tau_joint = T^T tau_motor; motor 6 turns with q5 + q6)."""
    trial = load_trial(DATA / "tx40_00.csv")
    assert trial.torque_kind == "measured" and trial.tau_meas is not None
    _, _, qm, tm = load_motor_trial(DATA / "tx40_00.csv")
    np.testing.assert_allclose(trial.q[0], 0.0, atol=2e-3)
    T = im.transmission_matrix()
    np.testing.assert_allclose(trial.tau_meas, tm @ T, rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(trial.q[:, 4] + trial.q[:, 5], qm[:, 5] / 32.0, atol=1e-9)
    np.testing.assert_allclose(trial.tau_meas[:, 4], 45.0 * tm[:, 4] + 32.0 * tm[:, 5], atol=1e-9)


def test_published_urdf_has_a_singular_mass_matrix():
    """As published, link_6 has zero inertia: M is singular (the workflow must cope)."""
    robot = Robot(URDF, im.JOINTS, {}, (0, 0, -9.81))
    M = pin.crba(robot.model, robot.model.createData(), np.array([0.1, 0.2, 0.3, 0.4, 0.5, 0.6]))
    M = np.triu(M) + np.triu(M, 1).T
    assert np.linalg.eigvalsh(M)[0] < 1e-9


def test_measured_torque_agrees_with_the_published_model():
    """Joints 1-3 on the committed 1 kHz slice: the URDF's inverse dynamics enters the measured torque with
    a gain near 1 and, with Coulomb + viscous + rotor inertia, explains >= 80 % of its rms. A wrong sign,
    gear ratio or joint offset in the sidecar breaks this. At rest (end of the log) joint 2 holds gravity."""
    coefs, ress, tau_rms = [], [], []
    for name in ("tx40_00.csv", "tx40_01.csv"):
        coef, res, tf = joint_fit(load_trial(DATA / name))
        coefs.append(coef)
        ress.append(res)
        tau_rms.append(np.sqrt(np.mean(tf**2, axis=0)))
    for coef, res, rms in zip(coefs, ress, tau_rms, strict=True):
        for j in range(3):
            assert 0.85 < coef[j, 0] < 1.15, f"joint_{j + 1}: rnea gain {coef[j, 0]:.3f}"
            assert coef[j, 1] > 0.5 and coef[j, 2] > 0.5, f"joint_{j + 1}: friction {coef[j, 1:3]}"
            assert res[j] < 0.2 * rms[j], f"joint_{j + 1}: residual {res[j]:.2f} of rms {rms[j]:.2f} N m"
    trial = load_trial(DATA / "tx40_01.csv")
    rest = trial.t > trial.t[-1] - 0.3
    model = trial.robot.model
    g = pin.computeGeneralizedGravity(model, model.createData(), trial.q[rest].mean(0))
    assert abs(g[1]) > 15.0
    # static friction on joint 2 is ~ 7 N m
    assert abs(trial.tau_meas[rest, 1].mean() - g[1]) < 0.25 * abs(g[1])


@pytest.mark.parametrize("argv, message", [
    (["--source", "nowhere", "--out", "o"], "not found"),
    (["--source", str(DATA / "source"), "--out", "o", "--urdf", str(URDF), "--window", "3:1"], "start < end"),
    (["--source", str(DATA / "source"), "--out", "o", "--urdf", str(URDF), "--window", "20:21"], "samples"),
])
def test_importer_cli_rejects_bad_input(tmp_path, capsys, argv, message):
    argv = [str(tmp_path / a) if a in ("o", "nowhere") else a for a in argv]
    assert im.main(argv) == 2
    assert message in capsys.readouterr().err
    assert not list((tmp_path / "o").glob("*.csv"))  # nothing written (a missing folder globs empty)


@pytest.mark.slow
def test_full_log_as_recorded(tmp_path):
    """The whole 45 000-sample log at 5 kHz, as recorded: same physical agreement on joints 1-3."""
    (path,) = im.convert(DATA / "source", tmp_path, [(0.0, 9.0)], urdf=URDF)
    trial = load_trial(path)
    assert len(trial.t) == 45000 and trial.rate_hz == 5000.0
    coef, res, tf = joint_fit(trial)
    rms = np.sqrt(np.mean(tf**2, axis=0))
    for j in range(3):
        assert 0.85 < coef[j, 0] < 1.15 and res[j] < 0.2 * rms[j], (j, coef[j], res[j], rms[j])
