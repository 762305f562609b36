"""Anything that ran re-runs bit for bit from what it wrote: a bound from its scenario.json, a study trial
from its record, both through `sparc-quad bound --scenario`; the Python API runs the same bound."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from sparc_quad.cli import main
from sparc_quad.study.records import load_records
from sparc_quad.study.runner import run_study
from sparc_quad.study.spec import parse_spec

pytestmark = pytest.mark.filterwarnings("ignore:steady window")


def _metrics(folder: Path) -> dict:
    m = json.loads((folder / "metrics.json").read_text())
    return {k: v for k, v in m.items() if k not in ("wall_time_s", "physics_wall_time_s", "config")}


def test_a_bound_reruns_from_its_scenario_json(tmp_path):
    first, again = tmp_path / "first", tmp_path / "again"
    assert main(["bound", "--duration", "1.5", "--kx", "700", "--seed", "5", "--no-plots", "--out",
                 str(first)]) == 0
    doc = json.loads((first / "scenario.json").read_text())
    assert doc["scenario"]["kx"] == 700.0 and doc["scenario"]["seed"] == 5 and doc["units"]["kx"] == "N/m"
    assert doc["metric_units"]["speed_m_s"] == "m/s" and doc["code_version"]
    header = (first / "timeseries.csv").read_text().split("\n", 1)[0]
    assert header.startswith("t [s],x [m],y [m],z [m],q1_true [rad]")
    rerun = ["bound", "--scenario", str(first / "scenario.json"), "--no-plots", "--out", str(again)]
    assert main(rerun) == 0
    assert (first / "timeseries.csv").read_bytes() == (again / "timeseries.csv").read_bytes()
    assert _metrics(first) == _metrics(again)
    # an option beside the file overrides its key
    third = tmp_path / "third"
    assert main(["bound", "--scenario", str(first / "scenario.json"), "--kx", "900", "--duration", "0.5",
                 "--no-plots", "--out", str(third)]) == 0
    assert json.loads((third / "scenario.json").read_text())["scenario"]["kx"] == 900.0


def test_a_study_trial_reruns_from_its_record(tmp_path):
    spec = parse_spec({"study": {"seeds": [3]}, "grid": {"kx": [600]},
                       "scenario": {"gait": "raibert", "duration": 1.5, "speed": 0.8}})
    run_study(spec, tmp_path / "study", workers=0, progress=False)
    (record,) = load_records(tmp_path / "study" / "trials")
    assert record["status"] == "ok" and record["scenario"]["seed"] == 3
    path = next((tmp_path / "study" / "trials").glob("*.json"))
    out = tmp_path / "rerun"
    assert main(["bound", "--scenario", str(path), "--no-plots", "--out", str(out)]) == 0
    again = _metrics(out)
    for name in ("speed_m_s", "cot_pos_total", "cot_abs_total", "stride_frequency_hz", "peak_spine_torque_nm",
                 "fell"):
        assert again[name] == record["metrics"][name], name


def test_the_python_api_runs_what_the_cli_runs(tmp_path):
    from sparc_quad import Scenario, run_bound, write_outputs

    assert main(["bound", "--duration", "1", "--speed", "0.7", "--no-plots", "--out",
                 str(tmp_path / "cli")]) == 0
    result = run_bound(Scenario(duration=1.0, speed=0.7))
    paths = write_outputs(result, tmp_path / "api", plots=False)
    assert {p.name for p in paths} >= {"scenario.json", "metrics.json", "timeseries.csv"}
    series = [(tmp_path / d / "timeseries.csv").read_bytes() for d in ("cli", "api")]
    assert series[0] == series[1]


def test_a_study_cell_on_the_node_path_runs_the_node_as_bound_does(tmp_path):
    """`spine_path = "node"` in a study cell runs the spine node, as `bound --spine-path node` does (a study
    trial ran the direct path whatever the key said), and both give the same series."""
    from sparc_quad.study.trial import run_trial

    m = run_trial({"gait": "raibert", "duration": 0.5, "spine_path": "node"})
    assert m["spine_path"] == "node"
    assert main(["bound", "--duration", "0.5", "--spine-path", "node", "--no-plots", "--out",
                 str(tmp_path / "b")]) == 0
    cli = json.loads((tmp_path / "b" / "metrics.json").read_text())
    assert cli["spine_path"] == "node" and cli["distance_m"] == m["distance_m"]
