"""The noise floor is never zero: at least what the sensors resolve and float64 precision allow.

On an ideal plant (no quantisation, no noise) the floor measured from the data alone is about 1e-6 N*m or
less (4.7e-16 N*m was seen), against which every residual is "unexplained"; the spine log's floor is held at
the CyberGear frames' and the load cell's resolution, and the report says which one set it.
"""

from __future__ import annotations

import json

import lcm
import numpy as np
import pytest

from sparc_quad.gap.lcm_log import spine_resolution
from sparc_quad.gap.workflow import run
from spine_module.messages import channels, codec

pytestmark = pytest.mark.integration  # a simulated session and the whole workflow, end to end


def _write_log(path, states) -> None:
    log = lcm.EventLog(str(path), "w", overwrite=True)
    for s in states:
        log.write_event(round(s.stamp_s * 1e6), channels.SPINE_STATE, codec.encode_state(s))
    log.close()


@pytest.fixture(scope="module")
def ideal_log(tmp_path_factory):
    from sparc_quad.robot_side.bench import run_inprocess
    from sparc_quad.robot_side.excitation import ident_script
    from sparc_quad.sim.plant import PlantConfig

    _, states = run_inprocess(ident_script(8.0), plant=PlantConfig().ideal())
    path = tmp_path_factory.mktemp("ideal") / "session.lcmlog"
    _write_log(path, states)
    return path


def test_floor_of_clean_data_is_the_sensors_resolution(ideal_log, tmp_path):
    rep = run([ideal_log], tmp_path / "gap", plots=False)
    floor = rep["noise_floor"]
    least = rep["noise_floor_resolution"]["floor_nm"]
    data = rep["noise_floor_heldout_final_model"]
    assert rep["noise_floor_resolution"]["resolution"] == spine_resolution()
    for j in floor:
        assert floor[j] >= least[j] > 1e-6, (j, floor[j], least[j])
    # the clean data's own floor is far below what the sensors resolve: the resolution sets it
    assert any(rep["noise_floor_set_by"][j] == "sensor_resolution" for j in floor), (data, least)
    parts = rep["noise_floor_resolution"]["parts_nm"]
    assert set(parts) == {"torque_lsb", "velocity_lsb_via_acceleration", "position_lsb",
                          "velocity_lsb_via_friction", "load_cell", "float64_precision"}
    assert all(v > 0 for v in parts["float64_precision"].values())
    np.testing.assert_allclose([least[j] ** 2 for j in least],
                               [sum(parts[k][j] ** 2 for k in parts) for j in least], rtol=1e-9)


def test_without_stated_resolution_the_floor_is_float64_precision(ideal_log, tmp_path):
    """A sidecar that states no sensor resolution: the least floor is the numbers' precision, > 0."""
    from sparc_quad.gap.lcm_log import default_meta

    meta = default_meta(ideal_log, 1000.0)
    meta.pop("resolution")
    meta["urdf"] = str((ideal_log.parent / meta["urdf"]).resolve())
    log = ideal_log.with_name("bare.lcmlog")
    log.write_bytes(ideal_log.read_bytes())
    log.with_suffix(".json").write_text(json.dumps(meta))
    rep = run([log], tmp_path / "gap", plots=False)
    least = rep["noise_floor_resolution"]["floor_nm"]
    assert all(0 < v < 1e-9 for v in least.values()), least
    assert all(v > 0 for v in rep["noise_floor"].values())


def test_split_log_runs_as_its_segments(ideal_log, tmp_path, capsys):
    """10 spine states lost in a row in the middle of a session: `gap run` takes the two segments as trials
    (one held out), lists the gap in the report and says so on the command line."""
    from sparc_quad.cli import main

    src = lcm.EventLog(str(ideal_log), "r")
    cut = tmp_path / "split.lcmlog"
    out = lcm.EventLog(str(cut), "w", overwrite=True)
    for ev in src:
        if not 4000 <= codec.decode(ev.channel, ev.data).seq < 4010:
            out.write_event(ev.timestamp, ev.channel, ev.data)
    out.close()
    assert main(["gap", "run", str(cut), "--out", str(tmp_path / "gap"), "--no-plots"]) == 0
    assert "2 segment(s) between 1 gap(s)" in capsys.readouterr().out
    rep = json.loads((tmp_path / "gap" / "report.json").read_text())
    src = rep["log_sources"][0]
    assert [g["lost"] for g in src["gaps"]] == [10] and src["gaps"][0]["after_seq"] == 3999
    assert [s["trial"] for s in src["segments"]] == ["split_seg00", "split_seg01"]
    blocks = [(t["block"], t["heldout"]) for t in rep["trials"]]
    assert blocks == [("split_seg00", False), ("split_seg01", True)]
