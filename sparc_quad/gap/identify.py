"""Inverse-dynamics residual, noise floor, the effect library and the fit used by the selection.

Residual (per joint, N*m) at decimated samples of zero-phase low-passed signals:
    r = F(applied(tau_cmd)) + F(friction(dq)) + J^T w - rnea(q_true, dq, ddq)
with the plant's actuator chain, friction, armature, payloads and encoder offset; ddq is the forward
difference of dq (the torque held over [t_k, t_k+1) is what changed dq_k into dq_k+1), then F.
Every candidate effect is a set of columns (linear in its amplitude) or a fixed column (a nonlinear map of
the commanded torque) computed at full rate, filtered by the same F and decimated; its shape parameter
(Stribeck velocity, delay, saturation limit, deadband width) is profiled on a grid and refined.
Fits: least squares on the training blocks, BIC on decimated samples (one sample per 1/(2 f_c)), each
joint whitened by its noise floor, held-out MSE per joint. The search over effects is `gap.select`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import minimize_scalar
from scipy.signal import butter, sosfiltfilt

from sparc_quad.gap.base_params import BaseParameters, regressor
from sparc_quad.gap.robot import Robot
from sparc_quad.gap.trial import Trial
from sparc_quad.sim.plant_effects import COUPLED, Effect, PlantEffects

BIC_MIN = 10.0
HELDOUT_MIN_PCT = 1.0
AMBIGUOUS_BIC = 6.0
HELDOUT_TIE = 1.1  # held-out MSE ratio under which two training-tied candidates stay ambiguous
MIN_CONTRIBUTION = 0.3  # an effect smaller than this x the noise floor changes the gap by < 5 %: not named
MOVING_FRACTION = 0.02  # a joint is moving where |dq| exceeds this fraction of its RMS velocity
EDGE_S = 0.15  # filter edge margin dropped at each end of a block


# ---- preprocessing ------------------------------------------------------------------------------------
@dataclass
class Block:
    """One contiguous block of one trial, filtered, with decimation indices."""

    trial: Trial
    robot: Robot
    cutoff_hz: float
    step: int  # decimation step in samples
    idx: np.ndarray = field(init=False)
    sos: np.ndarray = field(init=False, repr=False)

    def __post_init__(self):
        rate = self.trial.rate_hz
        self.sos = butter(4, self.cutoff_hz, fs=rate, output="sos")
        n = len(self.trial.t)
        edge = round(EDGE_S * rate)
        idx = np.arange(0, n, self.step)
        self.idx = idx[(idx >= edge) & (idx < n - edge - 1)]
        dq = self.trial.dq
        ddq = np.vstack([np.diff(dq, axis=0) / self.trial.dt, np.zeros((1, dq.shape[1]))])
        self.dq_f = self.F(dq)
        self.ddq_f = self.F(ddq)
        # friction over a step: f(dq_k) + f'(dq_k) (dq_k+1 - dq_k) / 2, the discretisation of
        # Robot.forward_step (second order in the step, like the midpoint value, and free of chatter)
        step_dq = np.vstack([np.diff(dq, axis=0), np.zeros((1, dq.shape[1]))])
        self.dq_act_raw = dq[:, self.robot.act_idx]
        self.half_step_dq = 0.5 * step_dq[:, self.robot.act_idx]
        self.dq_mid_f = self.F(dq + 0.5 * step_dq)
        self._qcache: dict = {}

    def F(self, x: np.ndarray, decimate: bool = True) -> np.ndarray:
        y = sosfiltfilt(self.sos, x, axis=0)
        return y[self.idx] if decimate else y

    def q_f(self, plant: PlantEffects) -> np.ndarray:
        key = tuple(plant.enc_offset)
        if key not in self._qcache:
            q = self.trial.q.copy()
            q[:, self.robot.act_idx] = plant.true_q(q[:, self.robot.act_idx])
            self._qcache = {key: self.F(q)}
        return self._qcache[key]

    @property
    def n(self) -> int:
        return len(self.idx)


def residual(block: Block, plant: PlantEffects) -> np.ndarray:
    """Inverse-dynamics residual (n_dec, nv), N*m (see module docstring)."""
    rb = block.robot
    tr = block.trial
    model = rb.plant_model(plant)
    q = block.q_f(plant)
    tau = np.zeros((block.n, rb.nv))
    fr, slope = plant.friction_and_slope(block.dq_act_raw)
    tau[:, rb.act_idx] = block.F(plant.applied_torque_series(tr.tau_cmd, tr.dt)
                                 + fr - slope * block.half_step_dq)
    if tr.f_ext is not None:
        tau += rb.ext_torque(q, block.F(tr.f_ext))
    tau[:, rb.act_idx] -= plant.coupled_inertia_torque(block.ddq_f[:, rb.act_idx])
    return tau - Robot.rnea(model, q, block.dq_f, block.ddq_f)


# ---- noise floor -----------------------------------------------------------------------------------------
def noise_floor(blocks: list[Block], residuals: list[np.ndarray]) -> tuple[np.ndarray, str]:
    """Per-joint RMS (N*m) of the residual part no model can explain.

    Repeated segments when the trials say their excitation has a period (`period_s`) and hold >= 2 of them:
    the spread of the residual across periods at equal phase (deterministic effects repeat, noise does
    not). Otherwise the high-frequency residual: robust scale of second differences of the decimated
    residual on the samples where the joint moves (|dq| > MOVING_FRACTION x its RMS), per joint (a rough
    bound that includes fast model errors).
    """
    per_sum, per_cnt = None, 0
    for b, r in zip(blocks, residuals, strict=True):
        period = b.trial.meta.get("period_s")
        if not period:
            continue
        P = round(period * b.trial.rate_hz)
        if P % b.step:
            continue
        phase = b.idx % P
        cyc = b.idx // P
        if cyc.max() - cyc.min() < 1:
            continue
        for ph in np.unique(phase):
            sel = phase == ph
            if sel.sum() >= 2:
                v = np.var(r[sel], axis=0, ddof=1)
                per_sum = v * (sel.sum() - 1) if per_sum is None else per_sum + v * (sel.sum() - 1)
                per_cnt += sel.sum() - 1
    if per_sum is not None and per_cnt >= 20:
        return np.sqrt(per_sum / per_cnt), "repeated_segments"
    d2 = np.vstack([np.diff(r, n=2, axis=0) for r in residuals])
    # moving samples only (a joint at rest holds its residual still: a floor from rest collapses to ~0)
    dq = np.vstack([b.dq_f[1:-1] for b in blocks])
    moving = np.abs(dq) > MOVING_FRACTION * np.sqrt(np.mean(dq**2, axis=0))
    mad = np.empty(d2.shape[1])
    for v in range(d2.shape[1]):
        x = d2[moving[:, v], v] if moving[:, v].sum() >= 20 else d2[:, v]
        mad[v] = np.median(np.abs(x - np.median(x))) * 1.4826
    # var(second difference) = sigma^2 (6 - 8 rho1 + 2 rho2), rho_k: the correlation the low-pass leaves
    # between decimated samples of white noise (the residual noise of the synthetic bench matches it)
    rho1, rho2 = filtered_white_correlation(blocks[0])
    return mad / math.sqrt(6.0 - 8.0 * rho1 + 2.0 * rho2), "high_frequency_residual"


def filtered_white_correlation(block: Block) -> tuple[float, float]:
    n = 8 * block.step + int(4 * block.trial.rate_hz / block.cutoff_hz)
    imp = np.zeros(2 * n + 1)
    imp[n] = 1.0
    h = sosfiltfilt(block.sos, imp)
    def rho(lag):
        return float(np.dot(h[:-lag], h[lag:]) / np.dot(h, h))
    return rho(block.step), rho(2 * block.step)


# ---- effect columns ------------------------------------------------------------------------------------
@dataclass(eq=False)
class Term:
    """One candidate or selected effect: fixed shape parameter `theta`, linear columns, fixed column."""

    name: str
    joint: str
    theta: float | None = None
    link: str | None = None
    xyz: np.ndarray | None = None
    direction: np.ndarray | None = None  # coupled_*: the motor's coordinate s = direction . q_actuated
    param_index: int | None = None  # link_inertia: standard-parameter column (10 (body - 1) + k)
    combination: str = ""  # link_inertia: the identifiable combination it stands for
    coef_index: int = -1  # index of its amplitude in the joint fit
    coef: float = float("nan")
    se: float = float("nan")
    theta_se: float = float("nan")

    @property
    def key(self) -> tuple:
        if self.param_index is None:
            return (self.name, self.joint)
        return (self.name, self.joint, self.param_index)

    @property
    def fixed(self) -> bool:
        return self.name in ("time_delay", "torque_saturation", "torque_deadband")

    @property
    def n_params(self) -> int:
        if self.name == "encoder_offset":  # theta is the linearisation point, tied to the amplitude
            return 1
        return (0 if self.fixed else 1) + (1 if self.theta is not None else 0)


class Library:
    """Computes columns for every effect on the blocks, with caching."""

    def __init__(self, blocks: list[Block], nominal: PlantEffects):
        self.blocks = blocks
        self.nominal = nominal
        self.robot = blocks[0].robot
        self.eps = nominal.eps
        self._cache: dict = {}
        self.models = [self.robot.plant_model(nominal)] * len(blocks)
        self._regressors: dict[int, np.ndarray] = {}
        self._base: BaseParameters | None = None

    def regressor(self, bi: int) -> np.ndarray:
        """(n_dec, nv, 10 nbodies) joint-torque regressor of block bi (nominal model, filtered signals)."""
        if bi not in self._regressors:
            b = self.blocks[bi]
            self._regressors[bi] = regressor(self.models[bi], b.q_f(self.nominal), b.dq_f, b.ddq_f)
        return self._regressors[bi]

    def base_parameters(self, train: list[int]) -> BaseParameters:
        if self._base is None:
            W = np.vstack([self.regressor(bi).reshape(-1, self.regressor(bi).shape[2]) for bi in train])
            self._base = BaseParameters(self.models[0], W)
        return self._base

    def joint_v(self, joint: str) -> int:
        return int(self.robot.act_idx[self.robot.actuated.index(joint)])

    def _put(self, b: Block, v: int, col_act: np.ndarray) -> np.ndarray:
        out = np.zeros((b.n, self.robot.nv))
        out[:, v] = col_act
        return out

    def column(self, term: Term, bi: int) -> np.ndarray:
        """(n_dec, nv) column for block bi (linear amplitude 1, or the fixed map)."""
        key = (term.name, term.joint, term.theta, term.param_index, bi)
        if key in self._cache:
            return self._cache[key]
        b = self.blocks[bi]
        rb = self.robot
        ja = rb.actuated.index(term.joint)
        v = self.joint_v(term.joint)
        dq = b.dq_act_raw[:, ja]
        half = b.half_step_dq[:, ja]
        th = np.tanh(dq / self.eps)
        dth = (1.0 - th**2) / self.eps
        if term.name in ("torque_gain", "time_delay", "torque_saturation", "torque_deadband"):
            tau = self.nominal.applied_torque_series(b.trial.tau_cmd, b.trial.dt)[:, ja]
        name = term.name
        if name == "coulomb_friction":
            col = self._put(b, v, b.F(th + dth * half))
        elif name == "link_inertia":
            col = self.regressor(bi)[:, :, term.param_index]
        elif name == "asymmetric_coulomb":
            col = self._put(b, v, b.F(np.abs(th) + np.sign(th) * dth * half))
        elif name in COUPLED:
            u = term.direction
            act = rb.act_idx
            out = np.zeros((b.n, rb.nv))
            if name == "coupled_rotor_inertia":
                sc = b.ddq_f[:, act] @ u
            elif name == "coupled_viscous_friction":
                sc = b.dq_mid_f[:, act] @ u
            else:
                sv, hs = b.dq_act_raw @ u, b.half_step_dq @ u
                ts = np.tanh(sv / self.eps)
                sc = b.F(ts + (1.0 - ts**2) / self.eps * hs)
            out[:, act] = sc[:, None] * u
            col = out
        elif name == "viscous_friction":
            col = self._put(b, v, b.dq_mid_f[:, v])
        elif name == "stribeck_friction":
            x = dq / term.theta
            e = np.exp(-(x**2))
            col = self._put(b, v, b.F(e * th + (e * dth - 2.0 * x / term.theta * e * th) * half))
        elif name == "rotor_inertia":
            col = self._put(b, v, b.ddq_f[:, v])
        elif name == "torque_gain":
            col = self._put(b, v, -b.F(tau))  # r = (1 - k) tau = -(k - 1) tau; amplitude = k - 1
        elif name == "torque_offset":
            col = self._put(b, v, -np.ones(b.n))
        elif name == "encoder_offset":
            q = b.q_f(self.nominal)
            if term.theta:  # secant through the estimate: exact at offset = theta
                qs = q.copy()
                qs[:, v] -= term.theta
                m = self.models[bi]
                col = (Robot.rnea(m, qs, b.dq_f, b.ddq_f) - Robot.rnea(m, q, b.dq_f, b.ddq_f)) / term.theta
            else:
                d = rb.rnea_dq(self.models[bi], q, b.dq_f, b.ddq_f)
                col = -d[:, :, v]
        elif name == "payload_mass":
            col = rb.point_mass_column(self.models[bi], term.joint, term.xyz, b.q_f(self.nominal),
                                       b.dq_f, b.ddq_f)
        elif name == "time_delay":
            s = round(term.theta / b.trial.dt)
            shifted = np.concatenate([np.full(s, tau[0]), tau[:-s]]) if s > 0 else tau
            col = self._put(b, v, b.F(tau - shifted))
        elif name == "torque_saturation":
            col = self._put(b, v, b.F(tau - np.clip(tau, -term.theta, term.theta)))
        elif name == "torque_deadband":
            col = self._put(b, v, b.F(np.sign(tau) * np.minimum(np.abs(tau), term.theta)))
        else:
            raise KeyError(name)
        if len(self._cache) > 4000:
            self._cache.clear()
        self._cache[key] = col
        return col


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
    """Stepwise selection over the library on training blocks, checked on held-out blocks."""

    def __init__(self, lib: Library, train: list[int], test: list[int], base_res: list[np.ndarray],
                 sigma: np.ndarray):
        self.lib, self.train, self.test = lib, train, test
        self.base = base_res
        self.w = 1.0 / np.maximum(sigma, 1e-9)
        self.robot = lib.robot
        self._flat_cache: dict = {}

    def _flat(self, t: Term, bi: int) -> np.ndarray:
        """The term's column for block bi, whitened and flattened joint by joint (cached)."""
        key = (t.name, t.joint, t.theta, t.param_index, bi)
        col = self._flat_cache.get(key)
        if col is None:
            if len(self._flat_cache) > 4000:
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

    def contribution(self, fit: Fit) -> float:
        """RMS of the last term's fitted contribution, in noise floors, on its most affected joint."""
        t = fit.terms[-1]
        blocks = self.test or self.train
        cols = np.vstack([self.lib.column(t, bi) for bi in blocks]) * self.w
        if not t.fixed:
            cols = cols * fit.beta[sum(not x.fixed for x in fit.terms) - 1]
        return float(np.max(np.sqrt(np.mean(cols**2, axis=0))))

    # ---- profiling grids -----------------------------------------------------------------------------
    def grid(self, name: str, joint: str) -> list[float] | None:
        lib = self.lib
        ja = self.robot.actuated.index(joint)
        if name == "stribeck_friction":
            dq = np.concatenate([np.abs(lib.blocks[b].dq_act_raw[:, ja]) for b in self.train])
            hi = max(float(np.percentile(dq, 90)), 0.02)
            return list(np.geomspace(0.01, hi, 14))
        if name == "time_delay":
            dt = lib.blocks[0].trial.dt
            return [s * dt for s in range(1, round(0.05 / dt) + 1)]
        tau = np.concatenate([np.abs(lib.blocks[b].trial.tau_cmd[:, ja]) for b in self.train])
        if name == "torque_saturation":
            pct = [*range(2, 90, 4), 90, 92, 94, 96, 97, 98, 99, 99.5, 99.8, 99.9, 99.95]
            return list(np.unique(np.percentile(tau, pct)))
        if name == "torque_deadband":
            top = float(np.percentile(tau, 50))
            return list(np.linspace(top / 25, top, 25))
        return None

    def _delay(self, selected: list[Term], joint: str) -> tuple[Term, Fit]:
        dt = self.lib.blocks[0].trial.dt
        s_max = max(1, round(0.05 / dt))
        s = _delay_search(lambda k: self.fit([*selected, Term("time_delay", joint, theta=k * dt)]).bic, s_max)
        best = self.fit([*selected, Term("time_delay", joint, theta=s * dt)])
        t = best.terms[-1]
        fm = self.fit([*selected, Term("time_delay", joint, theta=(s - 1) * dt)]).bic
        fp = self.fit([*selected, Term("time_delay", joint, theta=(s + 1) * dt)]).bic
        curv = (fp - 2 * best.bic + fm) / dt**2
        t.theta_se = math.sqrt(2.0 / curv) if curv > 0 else float("inf")
        return t, best

    def candidate(self, selected: list[Term], name: str, joint: str) -> tuple[Term, Fit]:
        grid = self.grid(name, joint)
        if name == "payload_mass":
            t = Term(name, joint, link=self.robot.child_link(joint), xyz=self.robot.link_com(joint))
            return t, self.fit([*selected, t])
        if name == "encoder_offset":  # Gauss-Newton: tangent, then secants through the estimate
            t = Term(name, joint)
            fit = self.fit([*selected, t])
            for _ in range(2):
                delta = float(fit.beta[sum(not x.fixed for x in fit.terms) - 1])
                if not (np.isfinite(delta) and 1e-6 < abs(delta) < 0.5):
                    break
                t = Term(name, joint, theta=delta)
                fit = self.fit([*selected, t])
            return t, fit
        if grid is None:
            t = Term(name, joint)
            return t, self.fit([*selected, t])
        if name == "time_delay":
            return self._delay(selected, joint)
        if len(grid) < 2:  # a constant signal: nothing to profile
            t = Term(name, joint, theta=grid[0] if grid else 0.0)
            return t, self.fit([*selected, t])
        fits = [self.fit([*selected, Term(name, joint, theta=g)]) for g in grid]
        bics = np.array([f.bic for f in fits])
        i = int(np.argmin(bics))
        theta, best = grid[i], fits[i]
        if name != "time_delay":
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
        h = lib_dt(self) if name == "time_delay" else max(abs(theta) * 0.02, 1e-4)
        try:
            fm = self.fit([*selected, Term(name, joint, theta=theta - h)]).bic
            fp = self.fit([*selected, Term(name, joint, theta=theta + h)]).bic
            curv = (fp - 2 * best.bic + fm) / h**2
            t.theta_se = math.sqrt(2.0 / curv) if curv > 0 else float("inf")
        except (ValueError, ZeroDivisionError):
            t.theta_se = float("nan")
        return t, best


def _delay_search(bic_of, s_max: int) -> int:
    """Integer delay (samples) in 1..s_max minimising bic_of: a geometric coarse grid, then brackets
    around the best point narrowed until every sample in the bracket has been tried (coarse to fine)."""
    seen: dict[int, float] = {}

    def f(s: int) -> float:
        if s not in seen:
            seen[s] = bic_of(s)
        return seen[s]

    pts = sorted({int(x) for x in np.unique(np.round(np.geomspace(1, s_max, 10)))})
    while True:
        vals = [f(p) for p in pts]
        i = int(np.argmin(vals))
        lo, hi = pts[max(i - 1, 0)], pts[min(i + 1, len(pts) - 1)]
        if hi - lo <= 8:
            for p in range(lo, hi + 1):
                f(p)
            return min(seen, key=seen.get)
        pts = sorted({int(x) for x in np.round(np.linspace(lo, hi, 7))})


def lib_dt(sel: Selector) -> float:
    return sel.lib.blocks[0].trial.dt


# ---- physical meaning, plausibility ------------------------------------------------------------------------
def term_params(t: Term) -> tuple[dict, dict]:
    """(params SI, standard errors) of a fitted term."""
    c, se = t.coef, t.se
    match t.name:
        case "coulomb_friction":
            return {"tau_c_nm": c}, {"tau_c_nm": se}
        case "viscous_friction":
            return {"b_nm_s_rad": c}, {"b_nm_s_rad": se}
        case "stribeck_friction":
            return {"tau_s_nm": c, "dq_s_rad_s": t.theta}, {"tau_s_nm": se, "dq_s_rad_s": t.theta_se}
        case "rotor_inertia":
            return {"inertia_kg_m2": c}, {"inertia_kg_m2": se}
        case "torque_gain":
            return {"gain": 1.0 + c}, {"gain": se}
        case "torque_offset":
            return {"offset_nm": c}, {"offset_nm": se}
        case "time_delay":
            return {"delay_s": t.theta}, {"delay_s": t.theta_se}
        case "payload_mass":
            return ({"mass_kg": c, "xyz_m": [float(x) for x in t.xyz]}, {"mass_kg": se})
        case "encoder_offset":
            return {"offset_rad": c}, {"offset_rad": se}
        case "torque_saturation":
            return {"limit_nm": t.theta}, {"limit_nm": t.theta_se}
        case "torque_deadband":
            return {"width_nm": t.theta}, {"width_nm": t.theta_se}
        case "asymmetric_coulomb":
            return {"delta_nm": c}, {"delta_nm": se}
        case "link_inertia":
            return ({"param_index": t.param_index % 10, "delta": c, "combination": t.combination},
                    {"delta": se})
        case "coupled_rotor_inertia" | "coupled_coulomb_friction" | "coupled_viscous_friction":
            key = {"coupled_rotor_inertia": "inertia_kg_m2", "coupled_coulomb_friction": "tau_c_nm",
                   "coupled_viscous_friction": "b_nm_s_rad"}[t.name]
            return {"direction": [float(x) for x in t.direction], key: c}, {key: se}
    raise KeyError(t.name)


def term_effect(t: Term) -> Effect:
    p, _ = term_params(t)
    return Effect(t.name, t.joint, p, t.link)
