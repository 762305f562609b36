"""Study spec: parsing, key-by-key validation, expansion (rigid does not vary k, d), hashing."""

from __future__ import annotations

import subprocess
import sys

import pytest

from sparc_quad.study.records import canonical, code_version, trial_hash
from sparc_quad.study.spec import SpecError, load_spec, parse_spec
from tests.paths import ROOT


def spec(**over):
    data = {
        "study": {"seeds": 2},
        "scenario": {"gait": "raibert", "duration": 1.0, "speed": 0.9},
        "grid": {"spine": ["impedance", "rigid"], "kx": [300, 800], "dx": [2, 8]},
    }
    for k, v in over.items():
        table, key = k.split("__")
        if v is None:
            data[table].pop(key, None)
        else:
            data[table][key] = v
    return data


def test_expansion_counts_and_rigid_collapses():
    s = parse_spec(spec())
    trials = s.trials()
    imp = [t for t in trials if t["spine"] == "impedance"]
    rigid = [t for t in trials if t["spine"] == "rigid"]
    assert len(imp) == 2 * 2 * 2  # k x d x seeds
    assert len(rigid) == 2  # seeds only: rigid does not vary k, d
    assert all("kx" not in t and "dx" not in t for t in rigid)
    assert {t["seed"] for t in trials} == {0, 1}
    assert all(t["gait"] == "raibert" and t["duration"] == 1.0 and t["speed"] == 0.9 for t in trials)
    assert s.size() == 16  # before the rigid cells collapse


def test_numbers_are_normalised_so_int_and_float_agree():
    a = parse_spec(spec(grid__kx=[800])).trials()
    b = parse_spec(spec(grid__kx=[800.0])).trials()
    assert [canonical(t) for t in a] == [canonical(t) for t in b]


def test_gait_list_and_seed_list():
    s = parse_spec(spec(scenario__gait=None, scenario__speed=None, grid__gait=["sine", "raibert"],
                        study__seeds=[3, 7]))
    trials = s.trials()
    assert {t["gait"] for t in trials} == {"sine", "raibert"}
    assert {t["seed"] for t in trials} == {3, 7}


@pytest.mark.parametrize(
    ("over", "names"),
    [
        ({"scenario__gait": "trot"}, "scenario.gait"),
        ({"scenario__duration": -1}, "scenario.duration"),
        ({"scenario__duration": "10"}, "scenario.duration"),
        ({"scenario__duration": 601}, "scenario.duration"),
        ({"scenario__duration": [1, 2]}, "scenario.duration"),
        ({"study__seeds": 0}, "study.seeds"),
        ({"study__seeds": 10**9}, "study.seeds"),
        ({"study__seeds": [1, 1]}, "study.seeds"),
        ({"study__speeds": [0.9]}, "study.speeds"),
        ({"grid__slope": [2.0]}, "grid.slope"),
        ({"study__colour": 1}, "study.colour"),
        ({"grid__spine": ["bendy"]}, "grid.spine"),
        ({"grid__kx": [300, "soft"]}, "grid.kx"),
        ({"grid__kx": [-5]}, "grid.kx"),
        ({"grid__kx": [1e12]}, "grid.kx"),
        ({"grid__dx": [float("nan")]}, "grid.dx"),
        ({"grid__duty": [1.5]}, "grid.duty"),
        ({"grid__frequency": [0]}, "grid.frequency"),
        ({"grid__wobble": [1]}, "grid.wobble"),
        ({"grid__speed": [1]}, "grid.speed"),  # also in [scenario]: one place
        ({"scenario__speed": None, "scenario__gait": "sine", "grid__speed": [1.0]}, "speed"),  # not in gait A
        ({"grid__kx": list(range(1, 101)), "grid__dx": list(range(1, 101)), "grid__kz": list(range(1, 21))},
         "more than"),
    ],
)
def test_bad_keys_are_named(over, names):
    with pytest.raises(SpecError, match=names.replace(".", r"\.")):
        parse_spec(spec(**over))


def test_load_spec_errors(tmp_path):
    with pytest.raises(SpecError, match="cannot read"):
        load_spec(tmp_path / "missing.toml")
    bad = tmp_path / "bad.toml"
    bad.write_text("[study\ngait=")
    with pytest.raises(SpecError, match="not valid TOML"):
        load_spec(bad)


def test_shipped_specs_parse():
    for path in sorted((ROOT / "studies").rglob("*.toml")):
        s = load_spec(path, check=path.name != "full.toml")  # full.toml: 7680 cells, sized only
        assert s.trials()


def test_hash_depends_on_config_and_version_not_key_order():
    a = {"gait": "raibert", "kx": 800.0, "seed": 0}
    b = {"seed": 0, "kx": 800.0, "gait": "raibert"}
    v = code_version()
    assert trial_hash(a, v) == trial_hash(b, v)
    assert trial_hash(a, v) != trial_hash({**a, "seed": 1}, v)
    assert trial_hash(a, v) != trial_hash(a, v + "x")
    assert v.startswith("0.") or "+src." in v


def test_code_version_tracks_trial_sources_only(tmp_path):
    """Editing a trial source changes the version; editing the study's report code does not."""
    for d in ("sparc_quad/sim", "sparc_quad/study", "spine_module"):
        (tmp_path / d).mkdir(parents=True)
    (tmp_path / "sparc_quad/sim/x.py").write_text("A = 1\n")
    (tmp_path / "sparc_quad/study/report.py").write_text("B = 1\n")
    (tmp_path / "spine_module/p.py").write_text("C = 1\n")
    v0 = code_version.__wrapped__(tmp_path)
    (tmp_path / "sparc_quad/study/report.py").write_text("B = 2\n")
    assert code_version.__wrapped__(tmp_path) == v0
    (tmp_path / "sparc_quad/sim/x.py").write_text("A = 2\n")
    assert code_version.__wrapped__(tmp_path) != v0


def test_cli_bad_spec_exits_2(tmp_path):
    bad = tmp_path / "s.toml"
    bad.write_text('[scenario]\ngait = "sine"\nduration = 1\n[grid]\nkx = ["x"]\n')
    r = subprocess.run(
        [sys.executable, "-m", "sparc_quad", "study", "run", str(bad), "--out", str(tmp_path / "o")],
        capture_output=True,
        text=True,
        cwd=ROOT,
        timeout=120,
    )
    assert r.returncode == 2
    assert "grid.kx" in r.stderr and "Traceback" not in r.stderr
    assert not (tmp_path / "o").exists()
