"""Section IV-A / Table IV / Fig. 4: quasi-static push-pull along x, stiffness by OLS.

A slow sinusoidal force F_x (period well above the spine's natural period, so inertia biases the slope by
< 0.2 %) pushes and pulls the end effector; the load cell reads F_x and the encoders give x by forward
kinematics, as on the paper's bench.
"""

from __future__ import annotations

import csv
import json
from collections.abc import Iterable
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from sparc_quad.experiments import rig
from sparc_quad.experiments.stats import chunk_slopes, ols
from sparc_quad.sim.forces import push_pull
from spine_module import params as P
from spine_module.model import SpineModel

# Table IV of the paper: k_d -> (n, k_hat, R², CI low, CI high, rel. err %, chunk mean, chunk SD)
PAPER_TABLE_IV = {
    300: (1331, 304.315, 0.9920, 302.846, 305.785, 1.44, 300.646, 11.239),
    400: (1428, 401.218, 0.9952, 399.776, 402.661, 0.30, 395.957, 18.206),
    500: (1795, 500.312, 0.9964, 498.914, 501.709, 0.06, 500.022, 6.909),
    600: (1950, 600.252, 0.9974, 598.896, 601.607, 0.04, 600.877, 7.210),
    700: (1840, 697.559, 0.9979, 696.097, 699.021, 0.35, 699.721, 7.259),
}


@dataclass(frozen=True)
class StaticConfig(rig.BenchConfig):
    """k_values N/m; k_z N/m; k_theta N*m/rad; d = (d_x N*s/m, d_z N*s/m, d_theta N*m*s/rad);
    amplitude_m: peak displacement the push aims for; period_s of one push-pull; cycles; one (x, F)
    pair every sample_every control steps."""

    k_values: tuple[float, ...] = P.BENCH_STATIC_K_X_N_M
    d: tuple[float, float, float] = rig.QUASI_STATIC_D
    amplitude_m: float = 0.025
    period_s: float = 8.0
    cycles: int = 2
    sample_every: int = 10
    n_chunks: int = 8
    controller: str = "impedance"


@dataclass
class StaticRow:
    k_cmd: float
    n: int
    k_hat: float
    r2: float
    ci95_low: float
    ci95_high: float
    rel_err_pct: float
    chunk_mean: float
    chunk_sd: float


def measure_stiffness(k: float, cfg: StaticConfig, model: SpineModel | None = None,
                      seed: int | None = None) -> tuple[StaticRow, np.ndarray, np.ndarray]:
    """One commanded k_x: returns the table row and the raw pairs (x − x_d in m, F_x in N)."""
    model = model or SpineModel()
    ctrl = rig.make_controller(cfg.controller, model, (k, cfg.k_z, cfg.k_theta), cfg.d)
    log = rig.run(ctrl, cfg.cycles * cfg.period_s, push_pull(k * cfg.amplitude_m, cfg.period_s),
                  plant=cfg.plant, seed=cfg.seed if seed is None else seed, sample_every=cfg.sample_every)
    x = log.x_meas[:, 0] - P.X_EQUILIBRIUM[0]
    f = log.f_cell
    fit = ols(x, f)
    chunks = chunk_slopes(x, f, cfg.n_chunks)
    row = StaticRow(k, fit.n, fit.slope, fit.r2, fit.ci95_low, fit.ci95_high,
                    100.0 * abs(fit.slope - k) / k, float(chunks.mean()), float(chunks.std(ddof=1)))
    return row, x, f


def run_static(cfg: StaticConfig, progress: Iterable[float] | None = None
               ) -> tuple[list[StaticRow], dict[float, tuple[np.ndarray, np.ndarray]]]:
    rows, raw = [], {}
    model = SpineModel()
    for k in (progress if progress is not None else cfg.k_values):
        row, x, f = measure_stiffness(float(k), cfg, model)
        rows.append(row)
        raw[float(k)] = (x, f)
    return rows, raw


def format_table(rows: list[StaticRow]) -> str:
    """Our rows beside the paper's Table IV."""
    head = (f"{'k_d':>5} | {'n':>5} {'k_hat':>9} {'R2':>7} {'CI95':>21} {'err%':>6} {'chunk':>16} || "
            f"paper: {'k_hat':>8} {'R2':>6} {'err%':>5}")
    lines = [head, "-" * len(head)]
    for r in rows:
        paper = PAPER_TABLE_IV.get(round(r.k_cmd))
        pk = f"{paper[1]:8.3f} {paper[2]:6.4f} {paper[5]:5.2f}" if paper else "     n/a"
        lines.append(f"{r.k_cmd:5.0f} | {r.n:5d} {r.k_hat:9.3f} {r.r2:7.4f}"
                     f" [{r.ci95_low:8.3f},{r.ci95_high:9.3f}] {r.rel_err_pct:6.2f}"
                     f" {r.chunk_mean:7.1f}±{r.chunk_sd:6.2f}   || paper: {pk}")
    lines.append("k_d: commanded k_x, N/m; n: push-pull pairs; k_hat: fitted stiffness (OLS of force on "
                 "displacement), N/m; R2 its fit; CI95 its 95 % interval, N/m; err%: |k_hat - k_d| / k_d; "
                 "chunk: k_hat of each of n_chunks consecutive slices of the pairs, mean ± SD, N/m (as the "
                 "paper's Table IV reports it); paper: the SPARC paper's Table IV")
    return "\n".join(lines)


def write_static(rows: list[StaticRow], raw: dict[float, tuple[np.ndarray, np.ndarray]], cfg: StaticConfig,
                 out: Path) -> None:
    """static.json (table rows), static.csv (raw pairs), static.png (Fig. 4)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out.mkdir(parents=True, exist_ok=True)
    doc = {"experiment": "static push-pull (paper Table IV, Fig. 4)", "controller": cfg.controller,
           "units": {"k": "N/m", "x": "m", "F_x": "N"},
           "config": {k: v for k, v in asdict(cfg).items() if k != "plant"},
           "plant": cfg.plant.to_json(), "rows": [asdict(r) for r in rows],
           "paper_table_iv": {str(k): dict(zip(["n", "k_hat", "r2", "ci95_low", "ci95_high", "rel_err_pct",
                                                "chunk_mean", "chunk_sd"], v, strict=True))
                              for k, v in PAPER_TABLE_IV.items()}}
    (out / "static.json").write_text(json.dumps(doc, indent=2))
    with (out / "static.csv").open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["k_cmd_n_m", "x_m", "f_x_n"])
        for k, (x, f) in raw.items():
            w.writerows((k, f"{xi:.7g}", f"{fi:.7g}") for xi, fi in zip(x, f, strict=True))
    fig, ax = plt.subplots(figsize=(7, 5))
    for r in rows:
        x, f = raw[r.k_cmd]
        pts = ax.plot(1e3 * x, f, ".", ms=2, alpha=0.35)[0]
        xs = np.linspace(x.min(), x.max(), 2)
        ax.plot(1e3 * xs, r.k_hat * xs + (f.mean() - r.k_hat * x.mean()), color=pts.get_color(),
                label=f"k_d={r.k_cmd:.0f}: k̂={r.k_hat:.1f} N/m, R²={r.r2:.4f}")
    ax.set_xlabel("displacement x − x_d (mm)")
    ax.set_ylabel("F_x (N)")
    ax.set_title(f"Static push-pull, {cfg.controller} controller (cf. paper Fig. 4)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out / "static.png", dpi=120)
    plt.close(fig)
