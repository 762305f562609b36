"""Section IV-C / Fig. 7: quasi-static displacements held by a hand, force read at rest, per k_x.

A stiff hand (a spring-damper along x only, `hand_k` N/m, `hand_d` N*s/m) drags the end effector to a
sequence of displacements and holds each; the load cell's mean over the last `read_s` of each hold is the
force, the ruler (true x from the rest pose before pulling) the displacement. Each trial starts from a
different random pose (seeded), so friction and gravity leave different rest states: the trial-to-trial
spread the paper shows. The same protocol runs with the impedance controller for comparison.
"""

from __future__ import annotations

import json
from collections.abc import Iterable
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from sparc_quad.experiments import rig
from sparc_quad.experiments.stats import ols
from sparc_quad.sim.bench_world import BenchWorld
from spine_module import params as P
from spine_module.model import SpineModel


@dataclass(frozen=True)
class PDConfig(rig.BenchConfig):
    """k_values N/m; displacements_m of the hand; trials per k; hold_s and read_s per displacement (s);
    settle_s before the ruler is zeroed; start_jitter_rad (1 sigma joint offset of each trial's start)."""

    k_values: tuple[float, ...] = P.BENCH_PD_K_X_N_M
    displacements_m: tuple[float, ...] = (0.005, 0.010, 0.015, 0.020, 0.025, 0.030)
    trials: int = 5
    d: tuple[float, float, float] = rig.QUASI_STATIC_D
    hand_k: float = 5000.0
    hand_d: float = 50.0
    ramp_s: float = 0.3
    hold_s: float = 0.5
    read_s: float = 0.1
    settle_s: float = 0.5
    start_jitter_rad: float = 0.02
    controllers: tuple[str, ...] = ("pd", "impedance")


@dataclass
class PDRow:
    controller: str
    k_cmd: float
    slope_mean: float  # mean over trials of the per-trial OLS slope, N/m
    slope_sd: float  # its trial-to-trial SD, N/m
    slope_pooled: float  # OLS over all trials' points, N/m
    r2_pooled: float
    force_mean_n: list[float]  # per displacement (Fig. 7 points)
    force_sd_n: list[float]
    displacement_mean_m: list[float]


def run_trial(controller: str, k: float, cfg: PDConfig, seed: int, model: SpineModel
              ) -> tuple[np.ndarray, np.ndarray]:
    """One trial: (displacement m, force N) at each hold."""
    rng = np.random.default_rng(seed)
    q0 = P.Q_EQUILIBRIUM.copy()
    q0[1:] += rng.normal(0.0, cfg.start_jitter_rad, 3)
    ctrl = rig.make_controller(controller, model, (k, cfg.k_z, cfg.k_theta), cfg.d)
    kin = model.create_data()
    dt = P.CONTROL_PERIOD_S
    n_settle, n_ramp, n_hold, n_read = (round(s / dt)
                                        for s in (cfg.settle_s, cfg.ramp_s, cfg.hold_s, cfg.read_s))
    disp, force = np.zeros(len(cfg.displacements_m)), np.zeros(len(cfg.displacements_m))
    f_ext = np.zeros(3)
    with BenchWorld(plant=cfg.plant, seed=seed, q0=q0) as world:
        def tick(hand_x: float | None) -> tuple[float, float]:
            q, dq = world.measured_joint_state()
            out = ctrl.step(q, dq)
            st = world.state()
            model.update_kinematics(kin, st.q, st.dq)
            f_ext[0] = 0.0 if hand_x is None else cfg.hand_k * (hand_x - kin.x[0]) - cfg.hand_d * kin.dx[0]
            world.step(out.tau, f_ext)
            return float(kin.x[0]), world.load_cell(f_ext[0])
        x_rest = 0.0
        for _ in range(n_settle):
            x_rest, _ = tick(None)
        hand = x_rest
        for j, target in enumerate(cfg.displacements_m):
            start = hand
            for i in range(n_ramp):
                hand = start + (x_rest + target - start) * (i + 1) / n_ramp
                tick(hand)
            xs, fs = [], []
            for i in range(n_hold):
                x, f = tick(hand)
                if i >= n_hold - n_read:
                    xs.append(x)
                    fs.append(f)
            disp[j], force[j] = np.mean(xs) - x_rest, np.mean(fs)
    return disp, force


def run_pd(cfg: PDConfig, progress: Iterable[tuple[str, float]] | None = None) -> list[PDRow]:
    model = SpineModel()
    rows = []
    pairs = progress if progress is not None else [(c, k) for c in cfg.controllers for k in cfg.k_values]
    for controller, k in pairs:
        trials = [run_trial(controller, k, cfg, cfg.seed * 1000 + i, model) for i in range(cfg.trials)]
        D = np.array([d for d, _ in trials])
        F = np.array([f for _, f in trials])
        slopes = np.array([ols(d, f).slope for d, f in trials])
        pooled = ols(D.ravel(), F.ravel())
        rows.append(PDRow(controller, k, float(slopes.mean()), float(slopes.std(ddof=1)) if len(slopes) > 1
                          else 0.0, pooled.slope, pooled.r2, F.mean(axis=0).tolist(),
                          F.std(axis=0, ddof=1).tolist() if len(F) > 1 else [0.0] * F.shape[1],
                          D.mean(axis=0).tolist()))
    return rows


def write_pd(rows: list[PDRow], cfg: PDConfig, out: Path) -> None:
    """pd.json (slopes per controller and k) and pd.png laid out as Fig. 7, impedance beside."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out.mkdir(parents=True, exist_ok=True)
    doc = {"experiment": "quasi-static displacement with a hand, PD vs impedance (paper Fig. 7)",
           "units": {"k": "N/m", "slope": "N/m", "force": "N", "displacement": "m"},
           "config": {k: v for k, v in asdict(cfg).items() if k != "plant"}, "plant": cfg.plant.to_json(),
           "rows": [asdict(r) for r in rows]}
    (out / "pd.json").write_text(json.dumps(doc, indent=2))
    ks = list(cfg.k_values)
    fig, axes = plt.subplots(1, len(ks), figsize=(3.2 * len(ks), 3.2), squeeze=False, sharey=True)
    for r in rows:
        ax = axes[0][ks.index(r.k_cmd)]
        d = 1e3 * np.array(r.displacement_mean_m)
        ax.errorbar(d, r.force_mean_n, yerr=r.force_sd_n, fmt="o-" if r.controller == "pd" else "s--",
                    capsize=3, ms=4, label=f"{r.controller}: {r.slope_mean:.0f}±{r.slope_sd:.0f} N/m")
        ax.set_title(f"k_x = {r.k_cmd:.0f} N/m", fontsize=9)
        ax.set_xlabel("displacement (mm)")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
    axes[0][0].set_ylabel("F_x (N), mean ± 1σ")
    fig.suptitle("Task-space PD (eq. 5) vs impedance (eq. 3), repeated quasi-static holds (cf. Fig. 7)")
    fig.tight_layout()
    fig.savefig(out / "pd.png", dpi=120)
    plt.close(fig)
