"""Gait B's search: evaluations judged after the ramp, several optimiser seeds, several perturbation seeds
per candidate, a convergence record (the trial function replaced by a known bowl: fast)."""

from __future__ import annotations

import itertools
import json

import pytest

from sparc_quad.study import raibert_opt as R


def test_search_restarts_seeds_and_convergence_record(monkeypatch):
    calls = []

    def fake(config):  # a bowl in frequency with its minimum at 4 Hz; seeds shift it slightly
        calls.append(config)
        cot = 0.5 + (config["frequency"] - 4.0) ** 2 + 0.01 * config["seed"]
        return {"cot_pos_total": cot, "fell": False, "speed_m_s": config["speed"], "window_s_0": 3.0}

    monkeypatch.setattr(R, "run_trial", fake)
    R._optimise.cache_clear()
    cfg = {"gait": "raibert-opt", "spine": "rigid", "speed": 0.9, "popsize": 4, "iterations": 3,
           "opt_restarts": 2, "opt_trial_seeds": 3, "opt_duration": 6.0}
    tuned = R.optimise_cell(cfg)
    assert tuned["_evaluations"] == 2 * 4 * 3 and len(calls) == 2 * 4 * 3 * 3
    assert {c["seed"] for c in calls} == {1, 2, 3} and all(c["duration"] == 6.0 for c in calls)
    curve = tuned["_convergence"]
    assert len(curve) == 24 and all(a >= b for a, b in itertools.pairwise(curve))  # best so far
    assert tuned["_objective"] == curve[-1] and tuned["_objective_at_half_budget"] == curve[11]
    assert abs(tuned["frequency"] - 4.0) < 0.5
    monkeypatch.setattr(R, "run_trial", lambda c: {**fake(c), "strides": []})
    m = R.run_optimised_trial({**cfg, "seed": 0, "duration": 6.0})
    assert json.loads(m["opt_convergence"]) == pytest.approx(list(curve), abs=1e-6)


def test_evaluations_shorter_than_six_seconds_are_refused():
    R._optimise.cache_clear()
    with pytest.raises(ValueError, match=r"opt_duration: must be in \[6, "):
        R.optimise_cell({"gait": "raibert-opt", "spine": "rigid", "opt_duration": 3.0})
