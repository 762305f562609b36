"""`gap run` on hostile inputs (issue 32, "Gap inputs"): every file and sidecar value is checked for type,
finiteness and physical range before any work; each case ends in exit 2 with one line naming the file and
key, no traceback, and nothing created (not even the output's parent folders). A plant file never holds a
NaN token."""

from __future__ import annotations

import json
import math
import os
from pathlib import Path

import pytest

from sparc_quad.cli import main
from sparc_quad.effects import PlantEffects, PlantEffectsError
from sparc_quad.gap.synth import synth
from tests.gap_helpers import copy_trial, edit_meta


@pytest.fixture(scope="module")
def good(tmp_path_factory) -> Path:
    d = tmp_path_factory.mktemp("hostile")
    return synth(d, [], seed=2, n_trials=1, periods=1, period_s=1.0)["trials"][0]




def _plant(p: Path, tmp_path: Path, edit) -> str:
    meta = json.loads(p.with_suffix(".json").read_text())
    d = json.loads(Path(meta["plant"]).read_text())
    edit(d)
    out = tmp_path / "plant_bad.json"
    out.write_text(json.dumps(d) if not isinstance(d, bytes) else d)
    return str(out)


def _cut_rows(p: Path) -> None:
    lines = p.read_text().splitlines()
    p.write_text("\n".join(lines[:200] + lines[700:]) + "\n")


def _param(d, key, value):
    for e in d["effects"]:
        if key in e["params"]:
            e["params"][key] = value
            return
    raise AssertionError(key)


# case -> (edit(trial, tmp) returning extra CLI args, text the one line must hold)
CASES = {
    "plant_not_utf8": (lambda p, t: ["--plant", str(_raw(t, b"\xff\xfe{}"))], "not UTF-8"),
    "plant_a_list": (lambda p, t: ["--plant", str(_raw(t, b"[1, 2]"))], "JSON object"),
    "plant_effects_not_list": (lambda p, t: ["--plant", _plant(p, t, lambda d: d.update(effects={}))],
                               "effects must be a list"),
    "plant_param_string": (lambda p, t: ["--plant", _plant(p, t, lambda d: _param(d, "tau_c_nm", "big"))],
                           "tau_c_nm (coulomb_friction) must be a number"),
    "plant_param_nan": (lambda p, t: ["--plant", str(_raw(t, _nan_plant(p)))], "must be finite"),
    "plant_inertia_negative": (lambda p, t: ["--plant", _plant(p, t, lambda d: _param(d, "inertia_kg_m2",
                                                                                       -1e5))],
                               "rotor inertia of q2 sums to"),
    "plant_inertia_huge": (lambda p, t: ["--plant", _plant(p, t, lambda d: _param(d, "inertia_kg_m2",
                                                                                   1e300))],
                           "not a physical value"),
    "plant_unknown_key": (lambda p, t: ["--plant", _plant(p, t, lambda d: d.update(frobnicate=1))],
                          "unknown key(s) ['frobnicate']"),
    "sidecar_gravity_huge": (lambda p, t: edit_meta(p, gravity=[0, 0, -1e300]), "gravity"),
    "sidecar_window_huge": (lambda p, t: edit_meta(p, dq_filter={"window_s": 1e308}), "dq_filter.window_s"),
    "sidecar_fixed_joint_huge": (lambda p, t: edit_meta(p, fixed_joints={"q1": 1e300}), "fixed_joints.q1"),
    "rows_cut_from_the_middle": (lambda p, t: _cut_rows(p), "time jumps from"),
    "sidecar_period_tiny": (lambda p, t: edit_meta(p, period_s=1e-300), "period_s 1e-300 s"),
    "fifo_as_trial": (lambda p, t: _fifo(p), "not a regular file"),
}


def _raw(tmp_path: Path, data: bytes) -> Path:
    out = tmp_path / "plant_raw.json"
    out.write_bytes(data)
    return out


def _nan_plant(p: Path) -> bytes:
    meta = json.loads(p.with_suffix(".json").read_text())
    text = Path(meta["plant"]).read_text()
    d = json.loads(text)
    _param(d, "tau_c_nm", math.nan)
    return json.dumps(d).encode()  # json writes the NaN token, as a careless tool would


def _fifo(p: Path) -> None:
    p.unlink()
    os.mkfifo(p)


@pytest.mark.parametrize("case", sorted(CASES))
def test_hostile_input_is_one_line_exit_2_nothing_created(good, tmp_path, capsys, case):
    edit, text = CASES[case]
    p = copy_trial(good, tmp_path, "trial")
    extra = edit(p, tmp_path) or []
    out = tmp_path / "zz" / "a" / "out"
    assert main(["gap", "run", str(p), "--out", str(out), "--no-plots", *extra]) == 2
    err = capsys.readouterr().err.strip()
    assert text in err and "Traceback" not in err and len(err.splitlines()) == 1, err
    assert not (tmp_path / "zz").exists()  # not even the output's parent folders


def test_missing_trial_creates_no_folders(tmp_path, capsys):
    out = tmp_path / "zz" / "a" / "out"
    assert main(["gap", "run", str(tmp_path / "nosuch.csv"), "--out", str(out)]) == 2
    assert "file not found" in capsys.readouterr().err and not (tmp_path / "zz").exists()


def test_plant_file_never_holds_a_nan_token(tmp_path):
    from sparc_quad.effects.base import Effect

    pe = PlantEffects(["q2"], [Effect("coulomb_friction", "q2", {"tau_c_nm": 0.1})])
    pe.effects[0].params["tau_c_nm"] = math.nan  # however it got there
    with pytest.raises(ValueError):
        pe.save(tmp_path / "p.json")
    with pytest.raises(PlantEffectsError, match="must be finite"):
        PlantEffects.from_dict({**pe.to_dict()})
