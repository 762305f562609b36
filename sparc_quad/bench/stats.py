"""Line fits with the statistics Table IV reports: OLS slope, R², analytic 95 % CI, chunk mean ± SD."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import stats


@dataclass(frozen=True)
class LineFit:
    slope: float
    intercept: float
    r2: float
    ci95_low: float
    ci95_high: float
    n: int


def ols(x: np.ndarray, y: np.ndarray) -> LineFit:
    """y = slope x + intercept by ordinary least squares; CI from the slope's t-distributed error."""
    x = np.asarray(x, dtype=float)
    y = np.asarray(y, dtype=float)
    if x.size < 3:
        raise ValueError(f"need at least 3 points for a line fit, got {x.size}")
    res = stats.linregress(x, y)
    t = stats.t.ppf(0.975, x.size - 2)
    return LineFit(float(res.slope), float(res.intercept), float(res.rvalue**2),
                   float(res.slope - t * res.stderr), float(res.slope + t * res.stderr), int(x.size))


def chunk_slopes(x: np.ndarray, y: np.ndarray, n_chunks: int) -> np.ndarray:
    """OLS slopes of n_chunks contiguous chunks: how steady the stiffness is along the recording."""
    idx = np.array_split(np.arange(len(x)), n_chunks)
    return np.array([ols(x[i], y[i]).slope for i in idx if len(i) >= 3])
