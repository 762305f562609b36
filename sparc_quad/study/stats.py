"""Study statistics: 95 % bootstrap CIs over seeds and strides, differences against rigid paired by seed,
fall rates with a Wilson interval.

A cell's trials are `groups`: one array per seed of its per-stride values (or a single per-trial value).
The two-level bootstrap draws seeds with replacement, then strides with replacement inside each drawn seed,
and averages seed means, so seeds weigh equally however many strides they have.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

CONFIDENCE = 0.95


@dataclass(frozen=True)
class Estimate:
    value: float  # point estimate (mean of the seeds' means; for ratios, ratio of those)
    lo: float | None  # 95 % interval; None when there is nothing to resample (a single value)
    hi: float | None
    n_seeds: int
    n_strides: int

    def overlaps(self, x: float) -> bool:
        """True if `x` lies inside the interval (or there is no interval)."""
        return self.lo is None or self.hi is None or self.lo <= x <= self.hi


def _clean(groups: Sequence) -> list[np.ndarray]:
    out = []
    for g in groups:
        a = np.atleast_1d(np.asarray(g, dtype=float))
        a = a[np.isfinite(a)]
        if a.size:
            out.append(a)
    return out


def _resampled_means(groups: list[np.ndarray], picks: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """(n_boot, n_seeds) means of a stride resample of the seed picked at each position."""
    out = np.empty(picks.shape)
    for s, g in enumerate(groups):
        mask = picks == s
        n = int(mask.sum())
        if not n:
            continue
        if g.size == 1:
            out[mask] = g[0]
        else:
            out[mask] = g[rng.integers(0, g.size, size=(n, g.size))].mean(axis=1)
    return out


def _interval(reps: np.ndarray) -> tuple[float, float]:
    a = (1.0 - CONFIDENCE) / 2.0
    lo, hi = np.quantile(reps, [a, 1.0 - a])
    return float(lo), float(hi)


def _resamplable(groups: list[np.ndarray]) -> bool:
    return len(groups) > 1 or any(g.size > 1 for g in groups)


def bootstrap_mean(groups: Sequence, n_boot: int = 2000, seed: int = 0) -> Estimate | None:
    """Mean over seeds of each seed's mean, with a two-level bootstrap 95 % interval."""
    gs = _clean(groups)
    if not gs:
        return None
    value = float(np.mean([g.mean() for g in gs]))
    n_str = int(sum(g.size for g in gs))
    if not _resamplable(gs):
        return Estimate(value, None, None, len(gs), n_str)
    rng = np.random.default_rng(seed)
    picks = rng.integers(0, len(gs), size=(n_boot, len(gs)))
    reps = _resampled_means(gs, picks, rng).mean(axis=1)
    lo, hi = _interval(reps)
    return Estimate(value, lo, hi, len(gs), n_str)


def paired_difference(
    cell: Mapping[int, Sequence],
    base: Mapping[int, Sequence],
    relative: bool = True,
    n_boot: int = 2000,
    seed: int = 0,
) -> Estimate | None:
    """Cell against the baseline, paired by seed: the same seeds are drawn for both, strides are drawn
    inside each. relative: 100 * (mean_cell / mean_base - 1) in %; else mean_cell - mean_base."""
    seeds = sorted(set(cell) & set(base))
    a = [_clean([cell[s]]) for s in seeds]
    b = [_clean([base[s]]) for s in seeds]
    keep = [i for i in range(len(seeds)) if a[i] and b[i]]
    if not keep:
        return None
    ga = [a[i][0] for i in keep]
    gb = [b[i][0] for i in keep]

    def stat(ma: np.ndarray, mb: np.ndarray) -> np.ndarray:
        return 100.0 * (ma / mb - 1.0) if relative else ma - mb

    ma0 = np.array([g.mean() for g in ga])
    mb0 = np.array([g.mean() for g in gb])
    value = float(stat(ma0.mean(), mb0.mean()))
    n_str = int(sum(g.size for g in ga))
    if not (_resamplable(ga) or _resamplable(gb)):
        return Estimate(value, None, None, len(keep), n_str)
    rng = np.random.default_rng(seed)
    picks = rng.integers(0, len(keep), size=(n_boot, len(keep)))
    reps = stat(_resampled_means(ga, picks, rng).mean(axis=1), _resampled_means(gb, picks, rng).mean(axis=1))
    lo, hi = _interval(reps)
    return Estimate(value, lo, hi, len(keep), n_str)


def wilson(count: int, n: int) -> tuple[float, float, float]:
    """(rate, lo, hi): a proportion with its 95 % Wilson score interval (statsmodels)."""
    from statsmodels.stats.proportion import proportion_confint

    if n <= 0:
        return float("nan"), 0.0, 1.0
    lo, hi = proportion_confint(count, n, alpha=1.0 - CONFIDENCE, method="wilson")
    return count / n, float(lo), float(hi)
