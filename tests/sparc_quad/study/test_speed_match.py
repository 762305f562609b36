"""Speed matched by design (study/speed_match.py): the calibration's steps, its convergence on a plant whose
speed is a known function of the input, and a study that calibrates each cell once, on seeds of its own."""

from __future__ import annotations

import json
import math

import pytest

from sparc_quad.study import speed_match
from sparc_quad.study.report import COMMANDED_SPEED_TOLERANCE_M_S, MATCHED, panel_target
from sparc_quad.study.runner import run_study
from sparc_quad.study.spec import SpecError, parse_spec
from sparc_quad.study.speed_match import MAX_STEP_RATIO, calibrate, next_value

CELL = {"gait": "authors-raibert", "host": "spined-dog", "engine": "mujoco", "duration": 4.0,
        "match_speed": 0.9, "match_seeds": 2, "match_iterations": 6}


class Plant:
    """A stand-in trial: speed = gain x command + offset (per spine), a small seed-dependent wobble; records
    every call."""

    def __init__(self, gain=0.8, offset=0.05, cap=math.inf, fall_above=math.inf):
        self.gain, self.offset, self.cap, self.fall_above = gain, offset, cap, fall_above
        self.calls: list[dict] = []

    def __call__(self, config: dict) -> dict:
        self.calls.append(dict(config))
        x = float(config["speed"])
        seed = int(config.get("seed", 0))
        v = min(self.cap, self.gain * x + self.offset + 0.002 * (seed % 3 - 1))
        fell = x > self.fall_above
        return {"speed_m_s": math.nan if fell else v, "fell": fell, "cot_pos_total": 1.0 + 0.01 * seed,
                "strides": [], "gait": config.get("gait"), "spine": config.get("spine", "impedance")}


@pytest.fixture
def plant(monkeypatch):
    p = Plant()
    monkeypatch.setattr(speed_match, "run_fixed_trial", p)
    speed_match._calibrate.cache_clear()
    yield p
    speed_match._calibrate.cache_clear()


def test_proportional_step_is_capped():
    assert next_value([(0.9, 0.3)], 0.9, 0.05, 3.0) == pytest.approx(0.9 * MAX_STEP_RATIO)
    assert next_value([(0.9, 0.6)], 0.9, 0.05, 3.0) == pytest.approx(0.9 * 0.9 / 0.6)
    assert next_value([(0.9, -0.1)], 0.9, 0.05, 3.0) == pytest.approx(0.9 * MAX_STEP_RATIO)  # backwards


def test_inside_a_bracket_it_interpolates():
    x = next_value([(1.0, 0.8), (1.2, 1.0)], 0.9, 0.05, 3.0)
    assert x == pytest.approx(1.1)


def test_a_point_without_speed_goes_half_way_back():
    assert next_value([(1.0, 0.8), (1.6, math.nan)], 0.9, 0.05, 3.0) == pytest.approx(1.3)
    # nothing to go back to: the gentler input (x 1/1.6), down to the bound, then nothing is left
    assert next_value([(1.0, math.nan)], 0.9, 0.05, 3.0) == pytest.approx(1.0 / MAX_STEP_RATIO)
    assert next_value([(0.06, math.nan), (0.05, math.nan)], 0.9, 0.05, 3.0) is None


def test_a_step_onto_an_input_that_fell_is_halved_back():
    """Fell at 0.08, stood at 0.05 running 0.54 (target 0.9): the x1.6 step lands on 0.08 again, so the
    search tries 0.065, between the two; a step onto an input with a speed ends the search as before."""
    assert next_value([(0.08, math.nan), (0.05, 0.54)], 0.9, 0.02, 0.2) == pytest.approx(0.065)
    assert next_value([(0.08, 0.7), (0.05, 0.54)], 0.9, 0.02, 0.2) is None


def test_a_bound_already_tried_ends_the_search():
    assert next_value([(3.0, 0.5)], 0.9, 0.05, 3.0) is None


def test_calibration_meets_the_target_on_its_own_seeds(plant):
    r = calibrate({**CELL, "seed": 7})
    assert r["converged"] and abs(r["achieved_m_s"] - 0.9) <= 0.01
    assert r["value"] == pytest.approx((0.9 - 0.05) / 0.8, abs=0.02)
    assert {c["seed"] for c in plant.calls} == {1000, 1001}  # never the reported seed
    n = len(plant.calls)
    assert calibrate({**CELL, "seed": 3}) == r and len(plant.calls) == n  # one calibration per cell


def test_an_unreachable_target_is_reported_not_met(plant):
    plant.cap = 0.7
    r = calibrate(CELL)
    assert not r["converged"] and r["achieved_m_s"] == pytest.approx(0.7, abs=0.003)
    assert len(r["history"]) <= CELL["match_iterations"]


def test_a_falling_cell_has_no_speed(plant):
    plant.fall_above = 0.05  # falls at every command the search may try
    r = calibrate(CELL)
    assert not r["converged"] and r["achieved_m_s"] is None and all(h[1] is None for h in r["history"])


def test_a_start_that_falls_steps_to_gentler_inputs(plant):
    """The start command falls; the search steps down until a point stands, then converges from there."""
    plant.fall_above = 0.5
    r = calibrate({**CELL, "match_speed": 0.35, "speed": 1.0})
    xs = [h[0] for h in r["history"]]
    assert r["history"][0][1] is None and xs[1] == pytest.approx(1.0 / MAX_STEP_RATIO)
    assert r["converged"] and r["value"] == pytest.approx((0.35 - 0.05) / 0.8, abs=0.02)


def test_seeds_that_disagree_give_no_speed(plant, monkeypatch):
    """A gait bimodal by seed (one calibration seed reverses): the seeds' mean lands on the target while no
    seed runs it, so the point has no speed and the calibration does not converge; each seed's speed is
    kept. Within the spread the same plant converges."""
    def bimodal(config):
        m = plant(config)
        if config["seed"] == 1000:
            m["speed_m_s"] -= 0.5  # another mode, 0.5 m/s slower: the mean is 0.25 m/s below seed 1001
        return m

    monkeypatch.setattr(speed_match, "run_fixed_trial", bimodal)
    cell = {**CELL, "match_speed": 0.45}
    r = calibrate(cell)
    assert not r["converged"] and r["achieved_m_s"] is None
    _x, v, nf, speeds = r["history"][0]
    assert v is None and nf == 0 and speeds[1] - speeds[0] == pytest.approx(0.5, abs=0.01)
    speed_match._calibrate.cache_clear()
    ok = calibrate({**cell, "match_spread": 2.0})  # told to accept any spread, it averages the modes
    assert ok["converged"]
    with pytest.raises(ValueError, match="match_spread"):
        speed_match.check_match({**CELL, "match_spread": 0})


def test_the_trial_runs_at_the_calibrated_input(plant):
    m = speed_match.run_matched_trial({**CELL, "seed": 4})
    assert plant.calls[-1]["seed"] == 4 and plant.calls[-1]["speed"] == m["match_value"]
    assert m["match_by"] == "speed" and m["match_converged"] and m["match_target_m_s"] == 0.9
    assert json.loads(m["match_history"])[-1][0] == m["match_value"]


def test_bad_match_keys_are_named():
    with pytest.raises(ValueError, match="match_by"):
        speed_match.check_match({**CELL, "match_by": "frequency"})  # not a command of gait C
    with pytest.raises(ValueError, match="match_speed"):
        speed_match.check_match({**CELL, "match_speed": -1.0})
    with pytest.raises(ValueError, match="calibration failed"):
        speed_match.check_match({**CELL, "matched": {"failed": "boom"}})
    with pytest.raises(ValueError, match="match_by"):
        speed_match.check_match({**CELL, "gait": "sine", "match_by": "speed"})


def test_a_spec_cannot_give_the_calibration():
    with pytest.raises(SpecError, match="matched"):
        parse_spec({"scenario": {**CELL, "matched": 1.0}}, check=False)


def test_the_panel_is_judged_at_the_target_like_a_command():
    target, source = panel_target({"gait": "authors-raibert", "match_speed": 0.5}, base_speed=0.8)
    assert (target, source) == (0.5, MATCHED)
    assert COMMANDED_SPEED_TOLERANCE_M_S == 0.03


def test_a_study_calibrates_each_cell_once_and_records_what_ran(plant, tmp_path):
    spec = parse_spec({"study": {"name": "m", "seeds": 3},
                       "scenario": {k: v for k, v in CELL.items() if k != "match_speed"},
                       "grid": {"match_speed": [0.5, 0.9], "spine": ["rigid", "passive"]}})
    s = run_study(spec, tmp_path, workers=0, progress=False)
    assert (s.executed, s.failed, s.calibrations) == (12, 0, 4)
    assert len(list((tmp_path / "calibrations").glob("*.json"))) == 4
    recs = [json.loads(p.read_text()) for p in (tmp_path / "trials").glob("*.json")]
    assert all("matched" not in r["config"] for r in recs)
    by_cell: dict = {}
    for r in recs:
        key = (r["config"]["match_speed"], r["config"]["spine"])
        by_cell.setdefault(key, set()).add(r["metrics"]["match_value"])
        assert r["scenario"]["speed"] == r["metrics"]["match_value"]  # `bound --scenario` runs this
        assert abs(r["metrics"]["match_calibration_speed_m_s"] - r["config"]["match_speed"]) <= 0.01
    assert all(len(v) == 1 for v in by_cell.values()) and len(by_cell) == 4
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["calibrations_run"] == 4
    n = len(plant.calls)
    again = run_study(spec, tmp_path, workers=0, progress=False)
    assert (again.executed, again.calibrations, len(plant.calls)) == (0, 0, n)


def test_a_failed_calibration_fails_its_trials_naming_it(plant, tmp_path, monkeypatch):
    def broken(config):
        raise RuntimeError("engine exploded")

    monkeypatch.setattr(speed_match, "run_fixed_trial", broken)
    spec = parse_spec({"study": {"name": "m", "seeds": 2}, "scenario": CELL})
    s = run_study(spec, tmp_path, workers=0, progress=False)
    assert s.failed == 2
    recs = [json.loads(p.read_text()) for p in (tmp_path / "trials").glob("*.json")]
    assert all("calibration failed" in r["error"] and "engine exploded" in r["error"] for r in recs)


def test_the_estimate_counts_the_calibration():
    from sparc_quad.cli.study import estimate_hours

    plain = parse_spec({"study": {"seeds": 10}, "scenario": {k: v for k, v in CELL.items()
                                                              if not k.startswith("match_")}}, check=False)
    matched = parse_spec({"study": {"seeds": 10}, "scenario": CELL}, check=False)
    # 10 seeds + at most 2 calibration seeds x 6 points per cell
    assert estimate_hours(matched, 1) == pytest.approx(estimate_hours(plain, 1) * (10 + 12) / 10)
