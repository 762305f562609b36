"""The cost of transport a study judges is each trial's whole window, energy / (m g x net forward
distance): a near-zero or backward stride cannot outweigh whole strides, and a trial that went backwards
has no cost of transport."""

from __future__ import annotations

import math

import pytest

from sparc_quad.metrics import cost_of_transport
from sparc_quad.study.report import Trial, analyse


def test_backwards_or_in_place_has_no_cost_of_transport():
    assert cost_of_transport(10.0, 1.0, 0.5, 10.0) == pytest.approx(2.0)
    assert math.isnan(cost_of_transport(10.0, 1.0, -0.5, 10.0))  # |d| made this 2.0
    assert math.isnan(cost_of_transport(10.0, 1.0, 0.0005, 10.0))


def _trial(seed: int, window_cot: float, stride_cots: list[float], spine: str = "impedance") -> Trial:
    metrics = {"cot_pos_total": window_cot, "fell": False, "speed_m_s": 0.9,
               "strides": [{"cot_pos_total": c} for c in stride_cots]}
    return Trial({"gait": "sine", "spine": spine, "kx": 800.0, "dx": 8.0, "seed": seed}, metrics, True, False)


def test_a_near_zero_stride_does_not_decide_the_cell():
    """The issue's case: a rigid-impedance trial whose strides of -0.019 m and -0.013 m gave per-stride CoT
    11.6 and 17.9 averaged 2.48 per stride against 1.06 over its window. The cell's estimate is the window
    value; the per-stride mean (the former estimand) would be 2.5 times it."""
    strides = [1.0] * 8 + [11.6, 17.9]
    trials = [_trial(s, 1.06, strides) for s in range(4)]
    assert trials[0].values("cot_pos_total") == [1.06]
    assert sum(strides) / len(strides) == pytest.approx(3.75)
    (cell,) = [c for c in analyse(trials, n_boot=50)["cells"] if c.metric == "cot_pos_total"]
    assert cell.est.value == pytest.approx(1.06)
    assert cell.est.n_seeds == 4 and cell.est.n_strides == 4  # one value per seed
