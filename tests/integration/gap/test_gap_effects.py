"""Every effect of the library, hidden alone in the bench spine, is named on its joint with its parameters
(within 10 % or 2 standard errors), and the held-out gap ends within 1.1x the noise floor.

Default suite: one seed per effect (the second seed of each is in the slow suite: the two seeds took
about 200 s of a 12.5-minute default suite on a 2-vCPU AMD EPYC VM). Slow suite: that seed and a sweep of
6 more per effect (the sweep's rate is printed)."""

from __future__ import annotations

import pytest

from tests.gap_helpers import EFFECT_CASES, check_named, run_case

FAST_SEEDS = (11, pytest.param(12, marks=pytest.mark.slow))
SLOW_SEEDS = tuple(range(100, 106))


@pytest.mark.parametrize("seed", FAST_SEEDS)
@pytest.mark.parametrize("name", list(EFFECT_CASES))
def test_effect_named(tmp_path, name, seed):
    rep, hidden = run_case(tmp_path, [EFFECT_CASES[name]], seed)
    errs = check_named(rep, hidden)
    assert not errs, errs


@pytest.mark.slow
def test_all_effects_sweep(tmp_path):
    failures, runs = [], 0
    for name, spec in EFFECT_CASES.items():
        for seed in SLOW_SEEDS:
            rep, hidden = run_case(tmp_path / f"{name}_{seed}", [spec], seed)
            runs += 1
            errs = check_named(rep, hidden)
            if errs:
                failures.append((name, seed, errs))
    rate = len(failures) / runs
    print(f"\nall-effects sweep: {runs - len(failures)}/{runs} named and closed ({100 * (1 - rate):.1f} %)")
    for f in failures:
        print("  failed:", f)
    assert rate <= 0.05, failures
