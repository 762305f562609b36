"""Line fits with the statistics Table IV reports: OLS slope, R², analytic 95 % CI, chunk mean ± SD."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import stats

from sparc_quad.robot_side.states import states_arrays
from spine_module import params as P


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


def stiffness_fit(states: list | dict[str, np.ndarray], x_d: float = P.X_EQUILIBRIUM[0],
                  skip_s: float = 0.0) -> LineFit:
    """The one stiffness estimator: OLS of the load-cell force against the node's x (its encoders and
    forward kinematics) minus x_d, N/m, over the node's spine states (list, or `states_arrays`) from
    `skip_s` on; rows without a load-cell reading (NaN) are left out."""
    a = states if isinstance(states, dict) else states_arrays(states)
    t, x, f = a["node_stamp_s"], a["node_x"][:, 0] - x_d, a["node_load_cell"][:, 0]
    sel = (t >= skip_s) & np.isfinite(x) & np.isfinite(f)
    return ols(x[sel], f[sel])


def stiffness_from_states(states: list | dict[str, np.ndarray], x_d: float = P.X_EQUILIBRIUM[0],
                          skip_s: float = 0.0) -> float:
    """`stiffness_fit(...).slope`, N/m."""
    return stiffness_fit(states, x_d, skip_s).slope
