"""The study's intervals cover: data simulated with a known mean (seed-to-seed and stride-to-stride
variance, autocorrelated strides, unequal stride counts) at 10 seeds."""

from __future__ import annotations

import numpy as np

from sparc_quad.study.stats import mean_over_seeds, paired_difference

N_SEEDS, REPS = 10, 300


def _ar1(rng, n: int, phi: float, sd: float) -> np.ndarray:
    e = rng.normal(0.0, sd * np.sqrt(1 - phi * phi), n)
    x = np.empty(n)
    x[0] = rng.normal(0.0, sd)
    for i in range(1, n):
        x[i] = phi * x[i - 1] + e[i]
    return x


def _seed_groups(rng, mean: float, seed_sd: float, stride_sd: float, phi: float) -> list[np.ndarray]:
    return [mean + rng.normal(0.0, seed_sd) + _ar1(rng, int(rng.integers(12, 40)), phi, stride_sd)
            for _ in range(N_SEEDS)]


def test_mean_interval_covers_at_10_seeds():
    rng = np.random.default_rng(20261202)
    for seed_sd, stride_sd, phi in ((0.05, 0.10, 0.7), (0.0, 0.10, 0.8), (0.10, 0.02, 0.3)):
        hit = 0
        for r in range(REPS):
            est = mean_over_seeds(_seed_groups(rng, 1.0, seed_sd, stride_sd, phi), n_boot=100, seed=r)
            hit += est.lo <= 1.0 <= est.hi
        assert hit / REPS >= 0.90, (seed_sd, stride_sd, phi, hit / REPS)


def test_paired_relative_difference_covers_at_10_seeds():
    rng = np.random.default_rng(7)
    hit = 0
    for r in range(REPS):
        base, cell = {}, {}
        for s in range(N_SEEDS):  # the seed shifts both cells alike (what pairing removes)
            shift = rng.normal(0.0, 0.08)
            base[s] = 1.0 + shift + _ar1(rng, int(rng.integers(12, 40)), 0.6, 0.08)
            cell[s] = 0.9 * (1.0 + shift) + _ar1(rng, int(rng.integers(12, 40)), 0.6, 0.08)
        d = paired_difference(cell, base, n_boot=100, seed=r)
        hit += d.lo <= -10.0 <= d.hi
    assert hit / REPS >= 0.90, hit / REPS


def test_coverage_check_can_fail():
    """A too-narrow interval (the stride-level naive SE, ignoring seeds) fails the same check."""
    rng = np.random.default_rng(1)
    hit = 0
    for _ in range(REPS):
        x = np.concatenate(_seed_groups(rng, 1.0, 0.05, 0.10, 0.7))
        h = 1.96 * x.std(ddof=1) / np.sqrt(x.size)
        hit += x.mean() - h <= 1.0 <= x.mean() + h
    assert hit / REPS < 0.90
