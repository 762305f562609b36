"""Section IV-B / Fig. 5: displace 0.037 m along x, release, compare with the ideal mass-spring-damper.

The ideal reference is m ẍ + b ẋ + k x = 0 with m the effective task-space mass at the equilibrium: the
modal mass k_x/ω² of the x-dominant mode of Λ ẍ + K x = 0 (model with rotor inertia). Eq. 3 does not
shape Λ, which is non-diagonal, so an x release also swings θ; the 1-D apparent mass 1/(J M⁻¹ Jᵀ)_xx,
reported beside it, misses that and predicts a period ~10 % too short. Trials differ by their noise
seed, which sets the hand's release (displacement jitter, 1 sigma `release_jitter_m`) as a person's
release differs from trial to trial.
"""

from __future__ import annotations

import json
import math
from collections.abc import Iterable
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import least_squares

from sparc_quad.experiments import rig
from spine_module import params as P
from spine_module.model import SpineModel

NOISE_FLOOR_FRACTION = 0.05  # amplitudes below 5 % of the release are not read for phase or growth


@dataclass(frozen=True)
class DynamicConfig(rig.BenchConfig):
    """k_values N/m, b_values N*s/m (d_x), displacement_m of the release, duration_s per trial,
    trials per case, release_jitter_m (1 sigma), the other axes' gains (N/m, N*m/rad, N*s/m, N*m*s/rad)."""

    k_values: tuple[float, ...] = P.BENCH_DYNAMIC_K_X_N_M
    b_values: tuple[float, ...] = P.BENCH_DYNAMIC_D_X_N_S_M
    displacement_m: float = 0.037
    duration_s: float = 1.5
    trials: int = 10
    release_jitter_m: float = 0.0005
    d_z: float = float(P.D_DEFAULT[1])
    d_theta: float = float(P.D_DEFAULT[2])
    sample_every: int = 2


@dataclass
class DynamicCase:
    k: float
    b: float
    m_eff_kg: float  # modal mass of the x mode, used by the ideal reference
    m_apparent_kg: float  # 1/(J M⁻¹ Jᵀ)_xx, for comparison
    zeta_ideal: float
    zeta_fit: float | None
    nrmse: float  # RMS(mean − ideal) / displacement
    phase_lag_first_rad: float | None  # at the first zero crossing
    phase_lag_last_rad: float | None  # at the last zero crossing both responses have
    phase_drift_rad: float | None  # last − first
    amplitude_growth: float | None  # last peak / first peak of |x − x_d|
    trials: int = 0


def ideal_response(t: np.ndarray, m: float, k: float, b: float, x0: float) -> np.ndarray:
    sol = solve_ivp(lambda _t, y: [y[1], -(b * y[1] + k * y[0]) / m], (0.0, float(t[-1])), [x0, 0.0],
                    t_eval=t, rtol=1e-10, atol=1e-12)
    return sol.y[0]


def zero_crossings(t: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Times where x changes sign, linearly interpolated."""
    s = np.signbit(x)
    idx = np.nonzero(s[1:] != s[:-1])[0]
    return t[idx] - x[idx] * (t[idx + 1] - t[idx]) / (x[idx + 1] - x[idx])


def peaks(x: np.ndarray, floor: float) -> np.ndarray:
    """|x| at its local extrema (one per half cycle) that stand above `floor` (m)."""
    a = np.abs(x)
    i = np.nonzero((a[1:-1] >= a[:-2]) & (a[1:-1] > a[2:]) & (a[1:-1] > floor))[0] + 1
    return a[i]


def fit_damping_ratio(t: np.ndarray, x: np.ndarray, k: float, m: float) -> float | None:
    """ζ of the damped oscillator that best fits x(t) (free x0, v0, ω_n, ζ)."""
    def model(p: np.ndarray) -> np.ndarray:
        x0, v0, wn, z = p
        return ideal_response_lin(t, wn, z, x0, v0)
    wn0 = math.sqrt(k / m)
    res = least_squares(lambda p: model(p) - x, [x[0], 0.0, wn0, 0.2],
                        bounds=([-1, -10, 0.3 * wn0, -0.5], [1, 10, 3 * wn0, 3.0]))
    return float(res.x[3]) if res.success else None


def ideal_response_lin(t: np.ndarray, wn: float, z: float, x0: float, v0: float) -> np.ndarray:
    """Closed-form free response of ẍ + 2ζω_n ẋ + ω_n² x = 0 (any ζ, including negative)."""
    if abs(1.0 - z * z) < 1e-9:
        return (x0 + (v0 + wn * x0) * t) * np.exp(-wn * t)
    if z < 1.0:
        wd = wn * math.sqrt(1.0 - z * z)
        return np.exp(-z * wn * t) * (x0 * np.cos(wd * t) + (v0 + z * wn * x0) / wd * np.sin(wd * t))
    r = wn * math.sqrt(z * z - 1.0)
    return np.exp(-z * wn * t) * (x0 * np.cosh(r * t) + (v0 + z * wn * x0) / r * np.sinh(r * t))


def run_trial(k: float, b: float, cfg: DynamicConfig, seed: int, model: SpineModel
              ) -> tuple[np.ndarray, np.ndarray]:
    """One release: time (s) and x − x_d (m) from encoder forward kinematics."""
    rng = np.random.default_rng(seed)
    x0 = P.X_EQUILIBRIUM + np.array([cfg.displacement_m + rng.normal(0.0, cfg.release_jitter_m), 0.0, 0.0])
    q0 = model.inverse_kinematics(x0)
    ctrl = rig.make_controller("impedance", model, (k, cfg.k_z, cfg.k_theta), (b, cfg.d_z, cfg.d_theta))
    log = rig.run(ctrl, cfg.duration_s, q0=q0, plant=cfg.plant, seed=seed, sample_every=cfg.sample_every)
    return log.t, log.x_meas[:, 0] - P.X_EQUILIBRIUM[0]


def analyse(k: float, b: float, t: np.ndarray, x_mean: np.ndarray, m: float, x0: float,
            m_apparent: float = float("nan")) -> DynamicCase:
    ideal = ideal_response(t, m, k, b, x0)
    zeta_ideal = b / (2.0 * math.sqrt(k * m))
    nrmse = float(np.sqrt(np.mean((x_mean - ideal) ** 2)) / x0)
    # phase is read only while the ideal oscillation stands above the noise floor
    wn = math.sqrt(k / m)
    visible = t <= (math.log(1.0 / NOISE_FLOOR_FRACTION) / (zeta_ideal * wn) if zeta_ideal > 0 else np.inf)
    zc_m, zc_i = zero_crossings(t[visible], x_mean[visible]), zero_crossings(t[visible], ideal[visible])
    first = last = drift = None
    n = min(len(zc_m), len(zc_i))
    if n >= 1:
        wd = wn * math.sqrt(max(1.0 - zeta_ideal**2, 1e-12))
        lags = (zc_m[:n] - zc_i[:n]) * wd  # time lag expressed as phase of the ideal oscillation
        first, last = float(lags[0]), float(lags[-1])
        drift = last - first if n >= 2 else None
    pk = peaks(x_mean, NOISE_FLOOR_FRACTION * x0)
    growth = float(pk[-1] / pk[0]) if len(pk) >= 2 else None
    zeta_fit = fit_damping_ratio(t, x_mean, k, m)
    return DynamicCase(k, b, m, m_apparent, zeta_ideal, zeta_fit, nrmse, first, last, drift, growth)


def run_dynamic(cfg: DynamicConfig, progress: Iterable[tuple[float, float]] | None = None
                ) -> tuple[list[DynamicCase], dict]:
    model = SpineModel()
    m_apparent = model.effective_mass_x(P.Q_EQUILIBRIUM)
    cases, curves = [], {}
    pairs = progress if progress is not None else [(k, b) for k in cfg.k_values for b in cfg.b_values]
    for k, b in pairs:
        m = model.modal_mass_x(P.Q_EQUILIBRIUM, np.array([k, cfg.k_z, cfg.k_theta]))
        runs = [run_trial(k, b, cfg, cfg.seed * 1000 + i, model) for i in range(cfg.trials)]
        t = runs[0][0] - runs[0][0][0]
        xs = np.array([x for _, x in runs])
        mean, sd = xs.mean(axis=0), xs.std(axis=0, ddof=1) if cfg.trials > 1 else np.zeros(len(t))
        case = analyse(k, b, t, mean, m, cfg.displacement_m, m_apparent)
        case.trials = cfg.trials
        cases.append(case)
        curves[(k, b)] = (t, mean, sd, ideal_response(t, m, k, b, cfg.displacement_m))
    return cases, curves


def write_dynamic(cases: list[DynamicCase], curves: dict, cfg: DynamicConfig, out: Path) -> None:
    """dynamic.json (per case metrics) and dynamic.png laid out as Fig. 5."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out.mkdir(parents=True, exist_ok=True)
    doc = {"experiment": "displace-and-release (paper Fig. 5)",
           "units": {"k": "N/m", "b": "N*s/m", "m_eff_kg": "kg", "phase": "rad", "nrmse": "fraction of the "
                     "release displacement"},
           "config": {k: v for k, v in asdict(cfg).items() if k != "plant"}, "plant": cfg.plant.to_json(),
           "cases": [asdict(c) for c in cases]}
    (out / "dynamic.json").write_text(json.dumps(doc, indent=2))
    ks, bs = cfg.k_values, cfg.b_values
    fig, axes = plt.subplots(len(ks), len(bs), figsize=(3.2 * len(bs), 2.6 * len(ks)), squeeze=False,
                             sharex=True)
    for (k, b), (t, mean, sd, ideal) in curves.items():
        ax = axes[ks.index(k)][bs.index(b)]
        ax.fill_between(t, 1e3 * (mean - sd), 1e3 * (mean + sd), alpha=0.3, label="±1σ")
        ax.plot(t, 1e3 * mean, lw=1.2, label="simulated mean")
        ax.plot(t, 1e3 * ideal, "k--", lw=1.0, label="ideal")
        ax.set_title(f"k={k:.0f} N/m, b={b:g} N·s/m", fontsize=9)
        ax.grid(alpha=0.3)
    for ax in axes[-1]:
        ax.set_xlabel("t (s)")
    for row in axes:
        row[0].set_ylabel("x − x_d (mm)")
    axes[0][0].legend(fontsize=7)
    fig.suptitle("Dynamic release, impedance control (cf. paper Fig. 5)")
    fig.tight_layout()
    fig.savefig(out / "dynamic.png", dpi=120)
    plt.close(fig)
