"""Study statistics on synthetic numbers with known answers."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats as sps

from sparc_quad.study.stats import mean_over_seeds, paired_difference, rate_difference, wilson


def test_wilson_known_values():
    # textbook Wilson score intervals (95 %)
    rate, lo, hi = wilson(0, 10)
    assert rate == 0.0 and lo == pytest.approx(0.0, abs=1e-12) and hi == pytest.approx(0.2775, abs=1e-4)
    rate, lo, hi = wilson(5, 10)
    assert (lo, hi) == pytest.approx((0.2366, 0.7634), abs=1e-4)
    _, lo, hi = wilson(10, 10)
    assert (lo, hi) == pytest.approx((0.7225, 1.0), abs=1e-4)


def test_seed_interval_matches_normal_theory():
    rng = np.random.default_rng(1)
    x = rng.normal(3.0, 1.0, size=400)
    est = mean_over_seeds([[v] for v in x])
    se = x.std(ddof=1) / np.sqrt(x.size)
    assert est.value == pytest.approx(x.mean())
    assert est.lo == pytest.approx(x.mean() - 1.96 * se, abs=0.2 * se)
    assert est.hi == pytest.approx(x.mean() + 1.96 * se, abs=0.2 * se)


def test_strides_resampled_within_seeds():
    # seeds identical in mean: the interval comes from stride scatter alone (block bootstrap inside each
    # seed), ~ sd / sqrt(total strides), with the t quantile of 4 seeds
    rng = np.random.default_rng(2)
    groups = [rng.normal(0.0, 1.0, 200) for _ in range(4)]
    groups = [g - g.mean() + 1.0 for g in groups]  # every seed mean exactly 1
    est = mean_over_seeds(groups)
    assert est.value == pytest.approx(1.0)
    se = 1.0 / np.sqrt(800)
    assert est.hi - est.lo == pytest.approx(2 * sps.t.ppf(0.975, 3) * se, rel=0.25)
    assert est.n_seeds == 4 and est.n_strides == 800


def test_seeds_weigh_equally_whatever_their_stride_count():
    est = mean_over_seeds([np.full(100, 1.0), np.full(2, 3.0)])
    assert est.value == pytest.approx(2.0)


def test_single_value_has_no_interval():
    est = mean_over_seeds([[1.5]])
    assert est.value == 1.5 and est.lo is None and est.overlaps(99.0)
    assert mean_over_seeds([[np.nan]]) is None


def test_pairing_by_seed_removes_between_seed_scatter():
    # seeds differ a lot (1 .. 3), every cell is exactly 10 % below its seed's rigid value
    rigid = {s: [v] for s, v in enumerate([1.0, 2.0, 3.0, 1.5, 2.5])}
    cell = {s: [0.9 * v[0]] for s, v in rigid.items()}
    d = paired_difference(cell, rigid)
    assert d.value == pytest.approx(-10.0)
    assert d.lo == pytest.approx(-10.0) and d.hi == pytest.approx(-10.0)
    assert not d.overlaps(0.0)
    # the same numbers unpaired would overlap: the cell's CI contains the rigid mean
    c = mean_over_seeds(list(cell.values()))
    assert c.lo < np.mean([v[0] for v in rigid.values()]) < c.hi


def test_paired_difference_absolute_and_unmatched_seeds():
    rigid = {0: [2.0, 2.0], 1: [4.0, 4.0], 7: [1.0]}
    cell = {0: [2.5, 2.5], 1: [4.5, 4.5], 9: [0.0]}
    d = paired_difference(cell, rigid, relative=False)
    assert d.value == pytest.approx(0.5) and d.n_seeds == 2
    assert paired_difference({3: [1.0]}, {4: [1.0]}) is None


def test_no_difference_overlaps_zero():
    rng = np.random.default_rng(3)
    rigid = {s: rng.normal(1.0, 0.05, 30) for s in range(5)}
    cell = {s: rng.normal(1.0, 0.05, 30) for s in range(5)}
    d = paired_difference(cell, rigid)
    assert d.overlaps(0.0)


def test_fall_rates_compared_by_their_interval():
    d, lo, hi = rate_difference(1, 3, 0, 3)  # 1/3 against 0/3: not distinguishable
    assert d == pytest.approx(1 / 3) and lo < 0 < hi
    d, lo, hi = rate_difference(9, 10, 0, 10)
    assert lo > 0


def test_fall_power_is_the_chance_falls_more_resolves_two_rates():
    """Exact power against a simulation of the same test; its false-alarm rate at equal rates stays under
    the one-sided 2.5 %; more seeds resolve more; the counts quoted are where the test turns."""
    import numpy as np

    from sparc_quad.study.stats import fall_power, falls_more, least_resolved, power_statement

    rng = np.random.default_rng(0)
    k_low, k_high = rng.binomial(10, 0.1, 4000), rng.binomial(10, 0.5, 4000)
    simulated = np.mean([falls_more(int(b), 10, int(a), 10) for a, b in zip(k_low, k_high, strict=True)])
    assert fall_power(10, 0.1, 0.5) == pytest.approx(simulated, abs=0.025)
    for p in (0.1, 0.3, 0.5):
        assert fall_power(10, p, p) <= 0.025
    assert fall_power(20, 0.1, 0.5) > fall_power(10, 0.1, 0.5)
    m = least_resolved(1, 10)
    assert falls_more(m, 10, 1, 10) and not falls_more(m - 1, 10, 1, 10)
    assert not falls_more(9, 10, 5, 10)  # the example: n = 10 cannot tell 9/10 from 5/10
    assert f"1/10 from {m}/10 or more" in power_statement(10)
