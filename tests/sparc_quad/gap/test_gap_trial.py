"""Trial I/O: round trip, and every kind of bad input is named by file, row and column."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from sparc_quad.gap.synth import synth
from sparc_quad.gap.trial import TrialError, load_lcm_log, load_trial
from tests.gap_helpers import copy_trial


@pytest.fixture(scope="module")
def good(tmp_path_factory) -> Path:
    d = tmp_path_factory.mktemp("trial")
    res = synth(d, [], seed=0, n_trials=1, periods=1, period_s=1.0)
    return res["trials"][0]



def _edit(path: Path, fn) -> None:
    lines = path.read_text().splitlines()
    fn(lines)
    path.write_text("\n".join(lines) + "\n")


def test_round_trip(good):
    tr = load_trial(good)
    assert tr.q.shape[1] == 3 and tr.tau_cmd.shape[1] == 3
    assert tr.robot.joints == ["q2", "q3", "q4"]
    assert np.all(np.diff(tr.t) > 0)


def test_missing_column(good, tmp_path):
    p = copy_trial(good, tmp_path)
    _edit(p, lambda L: L.__setitem__(0, L[0].replace("tau_cmd_q3", "tau_cmd_qX")))
    with pytest.raises(TrialError) as e:
        load_trial(p)
    assert e.value.column in ("tau_cmd_qX", "tau_cmd_q3") and str(p) in str(e.value)


def test_required_column_missing(good, tmp_path):
    p = copy_trial(good, tmp_path)
    def drop(L):
        for i, line in enumerate(L):
            L[i] = ",".join(line.split(",")[:-1])  # drops tau_cmd_q4
    _edit(p, drop)
    with pytest.raises(TrialError) as e:
        load_trial(p)
    assert e.value.column == "tau_cmd_q4"


def test_non_monotonic_time(good, tmp_path):
    p = copy_trial(good, tmp_path)
    def swap(L):
        L[10], L[11] = L[11], L[10]
    _edit(p, swap)
    with pytest.raises(TrialError) as e:
        load_trial(p)
    assert e.value.column == "t" and e.value.row == 11
    assert "row 11" in str(e.value)


def test_nan(good, tmp_path):
    p = copy_trial(good, tmp_path)
    def nan(L):
        f = L[5].split(",")
        f[2] = "nan"
        L[5] = ",".join(f)
    _edit(p, nan)
    with pytest.raises(TrialError) as e:
        load_trial(p)
    assert e.value.row == 5 and e.value.column == "q_q3"


def test_joint_not_in_urdf(good, tmp_path):
    p = copy_trial(good, tmp_path)
    meta = json.loads(p.with_suffix(".json").read_text())
    meta["actuated_joints"] = ["q2", "q3", "q9"]
    p.with_suffix(".json").write_text(json.dumps(meta))
    with pytest.raises(TrialError) as e:
        load_trial(p)
    assert "q9" in str(e.value) and str(p.with_suffix(".json")) in str(e.value)


def test_column_names_unknown_joint(good, tmp_path):
    p = copy_trial(good, tmp_path)
    _edit(p, lambda L: L.__setitem__(0, L[0] + ",q_q7") or [L.__setitem__(i, L[i] + ",0")
                                                           for i in range(1, len(L))])
    with pytest.raises(TrialError) as e:
        load_trial(p)
    assert e.value.column == "q_q7"


def test_missing_sidecar(good, tmp_path):
    p = tmp_path / "x.csv"
    shutil.copy(good, p)
    with pytest.raises(TrialError, match="sidecar"):
        load_trial(p)


def test_lcm_log_with_decoder(good, tmp_path):
    import lcm

    tr = load_trial(good)
    log_path = tmp_path / "run.lcm"
    meta = json.loads(copy_trial(good, tmp_path).with_suffix(".json").read_text())
    log_path.with_suffix(".json").write_text(json.dumps(meta))
    log = lcm.EventLog(str(log_path), "w", overwrite=True)
    for k in range(50):
        row = np.concatenate([[tr.t[k]], tr.q[k], tr.dq[k], tr.tau_cmd[k]])
        log.write_event(int(tr.t[k] * 1e6), "SPINE_STATE", row.astype("<f8").tobytes())
    log.close()

    def decoder(ev):
        a = np.frombuffer(ev.data, "<f8")
        return {"t": a[0], "q": a[1:4], "dq": a[4:7], "tau_cmd": a[7:10]}

    got = load_lcm_log(log_path, decoder)
    np.testing.assert_allclose(got.q, tr.q[:50])
    with pytest.raises(TrialError, match="no SPARC_SPINE_STATE events"):  # default: the node's codec
        load_lcm_log(log_path)
