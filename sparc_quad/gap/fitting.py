"""Least-squares fits of effect sets on the training blocks, scored by BIC and checked on held-out blocks.

Each joint is whitened by its noise floor; BIC on decimated samples (one sample per 1/(2 f_c)); held-out
MSE per joint. A candidate's shape parameter is profiled (`Selector.profile`) unless its kind searches it
its own way (`EffectKind.candidate`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import minimize_scalar

from sparc_quad.effects import Term, kind
from sparc_quad.gap.regressors import CACHE_MAX, Library


def ols(X: np.ndarray, y: np.ndarray, with_se: bool = False) -> tuple[np.ndarray, np.ndarray, float]:
    """(beta, standard errors (NaN unless with_se), RSS) of least squares y ~ X.

    Normal equations on unit-norm columns (k is small, a few dozen at most): one k x k solve, which stays
    fast on a loaded machine where LAPACK's threaded least-squares drivers slow down 50-fold; a badly
    conditioned design (cond > 1e10, estimated from the Cholesky factor) falls back to the k x k
    pseudo-inverse (minimum-norm solution). Standard errors as statsmodels' OLS
    (sigma^2 = RSS / (n - k))."""
    norm = np.sqrt(np.sum(X**2, axis=0))
    norm[norm == 0] = 1.0
    Xs = X / norm
    A = Xs.T @ Xs
    b = Xs.T @ y
    try:
        L = np.linalg.cholesky(A)
        d = np.diag(L)
        if (d.max() / d.min()) ** 2 > 1e10:  # condition number of A, estimated from its Cholesky factor
            raise np.linalg.LinAlgError
        bs = np.linalg.solve(A, b)
        Ainv = np.linalg.inv(A) if with_se else None
    except np.linalg.LinAlgError:  # (nearly) collinear columns: the minimum-norm solution
        Ainv = np.linalg.pinv(A, rcond=1e-10, hermitian=True)
        bs = Ainv @ b
    beta = bs / norm
    rss = float(np.sum((y - X @ beta) ** 2))
    if not with_se:
        return beta, np.full_like(beta, np.nan), rss
    dof = max(len(y) - X.shape[1], 1)
    se = np.sqrt(np.maximum(np.diag(Ainv), 0.0) * rss / dof) / norm
    return beta, se, rss


@dataclass
class Fit:
    terms: list[Term]
    bic: float
    rss: float
    n: int
    beta: np.ndarray
    se: np.ndarray
    heldout_mse: float
    heldout_mse_joint: np.ndarray | None = None  # per joint (whitened), on the held-out blocks


class Selector:
    """Fits of term sets on the training blocks (whitened by the noise floor), checked on held-out blocks."""

    def __init__(self, lib: Library, train: list[int], test: list[int], base_res: list[np.ndarray],
                 sigma: np.ndarray):
        self.lib, self.train, self.test = lib, train, test
        self.base = base_res
        self.w = 1.0 / np.maximum(sigma, 1e-9)
        self.least_floor = np.zeros(len(sigma))  # the sensors' least floor (N*m), set by the workflow
        self.robot = lib.robot
        self._flat_cache: dict = {}

    def _flat(self, t: Term, bi: int) -> np.ndarray:
        """The term's column for block bi, whitened and flattened joint by joint (cached)."""
        key = (t.name, t.joint, t.theta, t.param_index, bi)
        col = self._flat_cache.get(key)
        if col is None:
            if len(self._flat_cache) > CACHE_MAX:
                self._flat_cache.clear()
            col = self._flat_cache[key] = (self.lib.column(t, bi) * self.w).reshape(-1, order="F")
        return col

    def _design(self, terms: list[Term], blocks: list[int]):
        ys, xs = [], []
        lin = [t for t in terms if not t.fixed]
        for bi in blocks:
            y = self.base[bi].copy()
            for t in terms:
                if t.fixed:
                    y = y - self.lib.column(t, bi)
            ys.append((y * self.w).reshape(-1, order="F"))
            if lin:
                xs.append(np.column_stack([self._flat(t, bi) for t in lin]))
        y = np.concatenate(ys)
        X = np.vstack(xs) if lin else np.zeros((len(y), 0))
        return y, X, lin

    def fit(self, terms: list[Term], with_se: bool = False) -> Fit:
        y, X, _lin = self._design(terms, self.train)
        n = len(y)
        k = sum(t.n_params for t in terms)
        if X.shape[1]:
            beta, se, rss = ols(X, y, with_se)
        else:
            beta, se, rss = np.zeros(0), np.zeros(0), float(y @ y)
        bic = n * math.log(rss / n) + k * math.log(n)
        ho, ho_joint = float("nan"), np.full(self.robot.nv, np.nan)
        if self.test:
            yt, Xt, _ = self._design(terms, self.test)
            e = yt - Xt @ beta if Xt.shape[1] else yt
            ho = float(np.mean(e**2))
            sq, cnt, a = np.zeros(self.robot.nv), 0, 0
            for bi in self.test:  # per joint: each block is flattened column by column
                m = self.base[bi].shape[0]
                seg = e[a:a + m * self.robot.nv].reshape(m, self.robot.nv, order="F")
                sq += np.sum(seg**2, axis=0)
                cnt += m
                a += m * self.robot.nv
            ho_joint = sq / cnt
        return Fit(terms, bic, rss, n, beta, se, ho, ho_joint)

    def profile(self, selected: list[Term], name: str, joint: str,
                grid: list[float] | None) -> tuple[Term, Fit]:
        """The effect `name` on `joint` next to `selected`: its shape parameter profiled over `grid` (BIC),
        refined between the neighbours of the best point, its standard error from the BIC's curvature;
        no grid: the plain fit."""
        if grid is None:
            t = Term(name, joint)
            return t, self.fit([*selected, t])
        if len(grid) < 2:  # a constant signal: nothing to profile
            t = Term(name, joint, theta=grid[0] if grid else 0.0)
            return t, self.fit([*selected, t])
        fits = [self.fit([*selected, Term(name, joint, theta=g)]) for g in grid]
        bics = np.array([f.bic for f in fits])
        i = int(np.argmin(bics))
        theta, best = grid[i], fits[i]
        lo_b = grid[i - 1] if i > 0 else 0.5 * grid[0]
        hi_b = grid[i + 1] if i < len(grid) - 1 else grid[-1] + 0.5 * (grid[-1] - grid[-2])
        res = minimize_scalar(lambda g: self.fit([*selected, Term(name, joint, theta=g)]).bic,
                              bounds=(lo_b, hi_b), method="bounded",
                              options={"xatol": 1e-4 * abs(grid[i])})
        if res.fun < best.bic:
            theta = float(res.x)
            best = self.fit([*selected, Term(name, joint, theta=theta)])
        t = best.terms[-1]
        # standard error of theta from the curvature of n*log(RSS) (= -2 log L + const) at the optimum
        h = max(abs(theta) * 0.02, 1e-4)
        try:
            fm = self.fit([*selected, Term(name, joint, theta=theta - h)]).bic
            fp = self.fit([*selected, Term(name, joint, theta=theta + h)]).bic
            curv = (fp - 2 * best.bic + fm) / h**2
            t.theta_se = math.sqrt(2.0 / curv) if curv > 0 else float("inf")
        except (ValueError, ZeroDivisionError):
            t.theta_se = float("nan")
        return t, best

    def candidate(self, selected: list[Term], name: str, joint: str) -> tuple[Term, Fit]:
        """(term, fit) of the best version of effect `name` on `joint` (the kind decides how to search)."""
        return kind(name).candidate(self, selected, joint)
