"""Study statistics: seeds are the replicates; strides inside a seed are autocorrelated samples of it.

A cell's trials are `groups`: one array per seed of its per-stride values (or a single per-trial value).
Its estimate is the mean of the seeds' means (seeds weigh equally whatever their stride count), with a
t interval over seeds (n_seeds - 1 degrees of freedom) whose standard error is the larger of

- the between-seed one, sd(seed means) / sqrt(n_seeds), which already holds the stride scatter, and
- the within-seed one, sqrt(sum_s var_s) / n_seeds, var_s the variance of seed s's mean from a moving-block
  bootstrap over its strides (blocks of ~n^(1/3) strides keep their autocorrelation),

so a few seeds that happen to agree cannot shrink the interval below what their strides allow. With one
seed the interval is the block bootstrap's alone. Differences against a baseline are paired by seed (the
same perturbation), the relative one linearised (delta method). A two-level bootstrap with few seeds does
not cover (49 % at 2 seeds, nominal 95 %); `tests/sparc_quad/study/test_coverage.py` simulates data with a
known mean and checks this interval's coverage. Fall rates: Wilson intervals, compared by Newcombe's
interval of their difference, never by raw fractions.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
from scipy import stats as sps

CONFIDENCE = 0.95
N_BOOT = 400  # block-bootstrap draws per seed: enough for a variance (not a quantile)


@dataclass(frozen=True)
class Estimate:
    value: float  # point estimate
    lo: float | None  # 95 % interval; None when there is nothing to estimate it from (a single value)
    hi: float | None
    n_seeds: int
    n_strides: int
    per_seed: tuple[float, ...] = field(default=(), compare=False)  # each seed's value (seed order)
    method: str = ""

    def overlaps(self, x: float) -> bool:
        """True if `x` lies inside the interval (or there is no interval)."""
        return self.lo is None or self.hi is None or self.lo <= x <= self.hi

    def excludes(self, x: float) -> bool:
        """True if there is an interval and `x` lies outside it."""
        return not self.overlaps(x)


def _clean(g) -> np.ndarray:
    a = np.atleast_1d(np.asarray(g, dtype=float))
    return a[np.isfinite(a)]


def block_length(n: int) -> int:
    return max(1, round(n ** (1.0 / 3.0)))


def block_bootstrap_var(x: np.ndarray, n_boot: int = N_BOOT, seed: int = 0) -> float:
    """Variance of the mean of x (strides in time order) by a moving-block bootstrap; 0 for < 2 values."""
    n = x.size
    if n < 2:
        return 0.0
    b = block_length(n)
    k = math.ceil(n / b)
    rng = np.random.default_rng(seed)
    starts = rng.integers(0, n - b + 1, size=(n_boot, k))
    idx = (starts[:, :, None] + np.arange(b)).reshape(n_boot, -1)[:, :n]
    return float(x[idx].mean(axis=1).var(ddof=1))


def _t(df: int) -> float:
    return float(sps.t.ppf(0.5 + CONFIDENCE / 2.0, df))


def _interval(value: float, z: np.ndarray, within_var: float, n_boot: int, seed: int,
              one_seed: np.ndarray | None) -> tuple[float | None, float | None, str]:
    """value +- t * SE from per-seed linearised values z (mean 0 around value) and the within-seed
    variance of their mean."""
    n = z.size
    if n >= 2:
        se = max(float(z.std(ddof=1)) / math.sqrt(n), math.sqrt(within_var))
        h = _t(n - 1) * se
        return value - h, value + h, f"t over {n} seeds (df {n - 1}), SE max(between, within block bootstrap)"
    if one_seed is not None and one_seed.size >= 4:
        h = sps.norm.ppf(0.5 + CONFIDENCE / 2.0) * math.sqrt(within_var)
        return value - h, value + h, "one seed: block bootstrap over its strides only"
    return None, None, "no interval (one value)"


def mean_over_seeds(groups: Sequence, n_boot: int = N_BOOT, seed: int = 0) -> Estimate | None:
    """Mean over seeds of each seed's mean, with the t / block-bootstrap interval above."""
    gs = [a for a in (_clean(g) for g in groups) if a.size]
    if not gs:
        return None
    means = np.array([g.mean() for g in gs])
    value = float(means.mean())
    n = len(gs)
    within = sum(block_bootstrap_var(g, n_boot, seed + i) for i, g in enumerate(gs)) / n**2
    lo, hi, how = _interval(value, means - value, within, n_boot, seed, gs[0] if n == 1 else None)
    return Estimate(value, lo, hi, n, int(sum(g.size for g in gs)), tuple(float(m) for m in means), how)


def paired_difference(
    cell: Mapping[int, Sequence],
    base: Mapping[int, Sequence],
    relative: bool = True,
    n_boot: int = N_BOOT,
    seed: int = 0,
) -> Estimate | None:
    """Cell against the baseline over the seeds both have. relative: 100 * (mean_cell / mean_base - 1) in
    % (delta method on the per-seed pairs); else mean_cell - mean_base."""
    pairs = []
    for s in sorted(set(cell) & set(base)):
        a, b = _clean(cell[s]), _clean(base[s])
        if a.size and b.size:
            pairs.append((a, b))
    if not pairs:
        return None
    ma = np.array([a.mean() for a, _ in pairs])
    mb = np.array([b.mean() for _, b in pairs])
    va = np.array([block_bootstrap_var(a, n_boot, seed + i) for i, (a, _) in enumerate(pairs)])
    vb = np.array([block_bootstrap_var(b, n_boot, seed + 7919 + i) for i, (_, b) in enumerate(pairs)])
    n = len(pairs)
    if relative:
        abar, bbar = ma.mean(), mb.mean()
        if bbar == 0:
            return None
        r = abar / bbar
        value = 100.0 * (r - 1.0)
        z = 100.0 * (ma - r * mb) / bbar
        within = float((va + r * r * vb).sum()) * (100.0 / bbar) ** 2 / n**2
        per_seed = tuple(float(100.0 * (x / y - 1.0)) if y else math.nan for x, y in zip(ma, mb, strict=True))
    else:
        d = ma - mb
        value = float(d.mean())
        z = d - value
        within = float((va + vb).sum()) / n**2
        per_seed = tuple(float(x) for x in d)
    one = pairs[0][0] if n == 1 and pairs[0][0].size >= 4 else None
    lo, hi, how = _interval(value, z, within, n_boot, seed, one)
    return Estimate(float(value), lo, hi, n, int(sum(a.size for a, _ in pairs)), per_seed, how)


def wilson(count: int, n: int) -> tuple[float, float, float]:
    """(rate, lo, hi): a proportion with its 95 % Wilson score interval (statsmodels)."""
    from statsmodels.stats.proportion import proportion_confint

    if n <= 0:
        return float("nan"), 0.0, 1.0
    lo, hi = proportion_confint(count, n, alpha=1.0 - CONFIDENCE, method="wilson")
    return count / n, float(lo), float(hi)


def rate_difference(k1: int, n1: int, k2: int, n2: int) -> tuple[float, float, float]:
    """(p1 - p2, lo, hi): Newcombe's hybrid score interval (from the two Wilson intervals)."""
    p1, l1, u1 = wilson(k1, n1)
    p2, l2, u2 = wilson(k2, n2)
    d = p1 - p2
    return d, d - math.sqrt((p1 - l1) ** 2 + (u2 - p2) ** 2), d + math.sqrt((u1 - p1) ** 2 + (p2 - l2) ** 2)


def falls_more(k1: int, n1: int, k2: int, n2: int) -> bool:
    """Cell 1 falls more often than cell 2: the interval of the rate difference lies above 0."""
    return rate_difference(k1, n1, k2, n2)[1] > 0.0


def fall_power(n: int, p_low: float, p_high: float) -> float:
    """Chance that `falls_more` resolves a cell whose true fall rate is `p_high` against one at `p_low`,
    both run on `n` seeds (exact: every pair of binomial outcomes)."""
    from scipy.stats import binom

    lo, hi = binom.pmf(range(n + 1), n, p_low), binom.pmf(range(n + 1), n, p_high)
    return float(sum(hi[k2] * lo[k1] for k1 in range(n + 1) for k2 in range(n + 1)
                     if falls_more(k2, n, k1, n)))


def least_resolved(k_low: int, n: int) -> int | None:
    """The fewest falls out of `n` that `falls_more` tells from `k_low` out of `n` (None: none does)."""
    return next((k for k in range(k_low + 1, n + 1) if falls_more(k, n, k_low, n)), None)


def power_statement(n: int) -> str:
    """What `n` seeds per cell can tell of fall rates: the counts resolved, the chance to resolve two."""
    lows = sorted({0, n // 10, n // 2})

    def from_(m: int | None) -> str:
        return "from none" if m is None else f"only from {n}/{n}" if m == n else f"from {m}/{n} or more"

    told = "; ".join(f"{k}/{n} {from_(least_resolved(k, n))}" for k in lows)
    chances = ", ".join(f"{100 * a:.0f} % against {100 * b:.0f} %: {100 * fall_power(n, a, b):.0f} %"
                        for a, b in ((0.0, 0.3), (0.1, 0.5), (0.0, 0.5)))
    return (f"Power at n = {n} seeds per cell: a cell's falls are resolved as more than another's (Newcombe "
            f"95 % interval of the difference above 0) for {told}; true fall rates are resolved with "
            f"probability {chances}. A smaller difference is not evidence that two spines are equally "
            "robust.")


def ratio_interval(num: Sequence[float], den: Sequence[float]) -> Estimate | None:
    """mean(num) / mean(den) over paired replicates, t interval by the delta method."""
    a, b = np.asarray(num, float), np.asarray(den, float)
    ok = np.isfinite(a) & np.isfinite(b)
    a, b = a[ok], b[ok]
    if not a.size or b.mean() == 0:
        return None
    r = float(a.mean() / b.mean())
    z = (a - r * b) / b.mean()
    lo, hi, how = _interval(r, z, 0.0, 0, 0, None)
    return Estimate(r, lo, hi, a.size, a.size, tuple(float(x / y) if y else math.nan for x, y in
                                                     zip(a, b, strict=True)), how)
