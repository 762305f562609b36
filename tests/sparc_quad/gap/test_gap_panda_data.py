"""The real Franka Emika Panda log (tests/data/franka_panda): imported through `import_panda`, read by the
project's reader, and consistent with itself and with the Panda URDF of example-robot-data."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import signal

from sparc_quad.gap import import_panda as ip
from sparc_quad.gap.robot import Robot
from sparc_quad.gap.trial import load_trial
from tests.paths import DATA

SOURCE = DATA / "franka_panda" / "source"


@pytest.fixture(scope="module")
def trials(tmp_path_factory):
    out = tmp_path_factory.mktemp("panda")
    paths = ip.convert(SOURCE, out, [(0.0, 10.0), (10.0, 21.0)], rate_hz=1000.0, factor=4)
    return [load_trial(p) for p in paths]


def test_import_reads_back(trials):
    n = sum(len(tr.t) for tr in trials)
    assert 5000 <= n <= 5250  # 21 s at 250 Hz
    for tr in trials:
        assert tr.torque_kind == "measured" and tr.rate_hz == 250.0
        assert tr.robot.joints == ip.JOINTS
    np.testing.assert_allclose(trials[0].q[0], np.loadtxt(SOURCE / "gen_q0.txt"), atol=1e-4)


def test_logged_velocity_is_the_derivative_of_the_logged_position(trials):
    """Checks the sample-by-sample layout (7 values per time stamp) and the time stamps."""
    for tr in trials:
        b, a = signal.butter(4, 10.0 / (tr.rate_hz / 2))
        dq_num = signal.filtfilt(b, a, np.gradient(tr.q, tr.dt, axis=0), axis=0)
        dq_log = signal.filtfilt(b, a, tr.dq, axis=0)
        err = np.sqrt(np.mean((dq_num - dq_log)[50:-50] ** 2, axis=0))
        assert np.all(err < 0.02), err
        assert np.all(np.sqrt(np.mean(dq_log**2, axis=0)) > 0.1)  # every joint moves


def test_measured_torque_agrees_with_the_urdf(trials):
    """Joints 2-4 (gravity and inertia dominated): the URDF's inverse dynamics enters the sensed torque
    with a gain of 0.75-1.1 and, with Coulomb + viscous + inertia + offset, explains >= 85 % of its rms."""
    for tr in trials:
        b, a = signal.butter(4, 10.0 / (tr.rate_hz / 2))
        q = signal.filtfilt(b, a, tr.q, axis=0)
        dq = signal.filtfilt(b, a, tr.dq, axis=0)
        ddq = np.gradient(dq, tr.dt, axis=0)
        tau = signal.filtfilt(b, a, tr.tau_meas, axis=0)
        rnea = Robot.rnea(tr.robot.model, q, dq, ddq)
        for j in (1, 2, 3):
            moving = np.abs(dq[:, j]) > 0.05
            A = np.column_stack([rnea[:, j], np.sign(dq[:, j]), dq[:, j], ddq[:, j], np.ones(len(q))])[moving]
            coef, *_ = np.linalg.lstsq(A, tau[moving, j], rcond=None)
            res = np.sqrt(np.mean((tau[moving, j] - A @ coef) ** 2))
            rms = np.sqrt(np.mean(tau[moving, j] ** 2))
            assert 0.75 < coef[0] < 1.1, (j, coef)
            assert res < 0.15 * rms, (j, res, rms)


def test_importer_cli_rejects_bad_input(tmp_path, capsys):
    assert ip.main(["--source", str(tmp_path / "none"), "--out", str(tmp_path / "o")]) == 2
    assert "file not found" in capsys.readouterr().err
    assert ip.main(["--source", str(SOURCE), "--out", str(tmp_path / "o"), "--window", "30:40"]) == 2
    assert "samples" in capsys.readouterr().err
    assert not (tmp_path / "o").exists()
