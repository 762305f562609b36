"""The study report's plots, from `report.analyse`'s cells (matplotlib, Agg).

Read at a glance: per-seed points beside each cell's mean and interval, the seed count, off-speed cells
marked (hollow / dotted), fully fallen cells drawn as fallen (never interpolated over), the baselines as
visible bands, legs and spine split, and each cell's gait frequency against the spine's f_n(k).
"""

from __future__ import annotations

import json
import math
from collections.abc import Iterable
from pathlib import Path

import numpy as np

from sparc_quad.metrics import label
from sparc_quad.study.records import atomic_write_text

SPINES = ("impedance", "passive")
BASE_COLOURS = {"rigid": "0.35", "rigid-impedance": "tab:purple"}


def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _fmt(x: float | None, nd: int = 2) -> str:
    return "–" if x is None or not math.isfinite(x) else f"{x:.{nd}f}"


def natural_frequencies(ks: Iterable[float], cache: Path) -> dict[float, float]:
    """f_n(k) from the free-oscillation test (sparc_quad.sim.spine_resonance), cached in `cache`."""
    have: dict[str, float] = {}
    if cache.is_file():
        try:
            have = json.loads(cache.read_text())
        except ValueError:
            have = {}
    from sparc_quad.sim.spine_resonance import spine_natural_frequency_hz

    out = {}
    for k in ks:
        key = f"{float(k):g}"
        if key not in have:
            have[key] = float(spine_natural_frequency_hz(float(k)))
        out[float(k)] = have[key]
    atomic_write_text(cache, json.dumps(have, indent=1) + "\n")
    return out


def _mine(panel: dict, metric: str, cells: list) -> list:
    return [c for c in cells if c.panel == panel["panel"] and c.metric == metric]


def _spines(mine: list) -> list[str]:
    return [s for s in SPINES if any(c.spine == s for c in mine)] + sorted(
        {c.spine for c in mine} - set(SPINES) - set(BASE_COLOURS)
    )


def _baseline_text(mine: list) -> str:
    parts = []
    for c in mine:
        if c.spine in BASE_COLOURS and c.est is not None:
            e = c.est
            parts.append(
                f"{c.spine} {_fmt(e.value)} [{_fmt(e.lo)}, {_fmt(e.hi)}] at "
                f"{_fmt(c.extras.get('speed_m_s'))} m/s, holding torque RMS "
                f"{_fmt(c.extras.get('spine_torque_rms_nm'))} N·m"
            )
        elif c.spine in BASE_COLOURS:
            parts.append(f"{c.spine}: fell {c.n_fell}/{c.n}")
    return "; ".join(parts) or "no baseline"


def plot_heatmap(panel: dict, metric: str, cells: list, path: Path) -> Path | None:
    """% against each cell's baseline over k x d, one panel per spine; the colour scale spans the largest
    difference shown (no saturation)."""
    plt = _plt()
    from matplotlib.colors import TwoSlopeNorm
    from matplotlib.patches import Rectangle

    mine = _mine(panel, metric, cells)
    spines = _spines(mine)
    if not spines:
        return None
    ks = sorted({c.k for c in mine if c.spine in spines and c.k is not None}) or [None]
    ds = sorted({c.d for c in mine if c.spine in spines and c.d is not None}) or [None]
    diffs = [
        abs(c.diff_pct.value) for c in mine if c.diff_pct is not None and math.isfinite(c.diff_pct.value)
    ]
    lim = max(5.0, max(diffs, default=5.0))
    norm = TwoSlopeNorm(vmin=-lim, vcenter=0.0, vmax=lim)
    fig, axes = plt.subplots(
        1,
        len(spines),
        figsize=(max(7.0, 2.0 * len(ks) * len(spines) + 1.8), 1.25 * len(ds) + 2.8),
        squeeze=False,
        constrained_layout=True,
    )
    im = None
    for ax, spine in zip(axes[0], spines, strict=True):
        grid = np.full((len(ds), len(ks)), np.nan)
        for c in mine:
            if c.spine == spine and c.diff_pct is not None:
                grid[ds.index(c.d), ks.index(c.k)] = c.diff_pct.value
        im = ax.imshow(grid, cmap="RdBu_r", norm=norm, origin="lower", aspect="auto")
        for c in mine:
            if c.spine != spine:
                continue
            i, j = ds.index(c.d), ks.index(c.k)
            if c.all_fell:
                ax.add_patch(Rectangle((j - 0.5, i - 0.5), 1, 1, color="0.25"))
                ax.text(j, i, f"FELL\n{c.n_fell}/{c.n}", ha="center", va="center", fontsize=9, color="w")
                continue
            lines = [_fmt(c.est.value if c.est else None)]
            if c.diff_pct is not None:
                d = c.diff_pct
                lines.append(f"{d.value:+.0f}% [{_fmt(d.lo, 0)},{_fmt(d.hi, 0)}]")
            lines.append(f"{_fmt(c.extras.get('speed_m_s'))} m/s, n={c.est.n_seeds if c.est else 0}")
            if c.n_fell:
                lines.append(f"fell {c.n_fell}/{c.n}")
            if c.off_speed:
                lines.append("OFF-SPEED")
            dark = c.diff_pct is not None and abs(c.diff_pct.value) > 0.6 * lim
            ax.text(
                j, i, "\n".join(lines), ha="center", va="center", fontsize=7.5, color="w" if dark else "k"
            )
            hatch = ("xx" if c.n_fell else "") + (
                "///" if c.diff_pct is None or c.diff_pct.overlaps(0) else ""
            )
            if hatch:
                ax.add_patch(
                    Rectangle((j - 0.5, i - 0.5), 1, 1, fill=False, hatch=hatch, edgecolor="0.55", lw=0)
                )
            if c.off_speed:
                ax.add_patch(Rectangle((j - 0.47, i - 0.47), 0.94, 0.94, fill=False, ls=":", lw=2, ec="k"))
        ax.set_xticks(range(len(ks)), [_fmt(k, 0) for k in ks])
        ax.set_yticks(range(len(ds)), [_fmt(d, 0) for d in ds])
        ax.set_xlabel("k_x (N/m)")
        ax.set_ylabel("d_x (N·s/m)")
        base = next((c.baseline for c in mine if c.spine == spine and c.baseline), None)
        ax.set_title(f"{spine} spine against {base or 'no baseline'}", fontsize=10)
    if im is not None:
        fig.colorbar(im, ax=axes[0].tolist(), shrink=0.9).set_label("% against the baseline (blue = cheaper)")
    target = panel.get("target_speed_m_s")
    fig.suptitle(
        f"{panel['panel']}: {label(metric)}; target speed {_fmt(target)} m/s ({panel.get('target_source')})\n"
        f"{_baseline_text(mine)}\ncell: mean, % vs baseline [95 % CI], speed, seeds; hatched xx a trial "
        "fell, /// CI contains 0; dotted box: > 0.05 m/s off target (not judged); dark: every trial fell",
        fontsize=8,
    )
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def _draw_cost(ax, mine_m: list, spine: str, fn: dict) -> None:
    for c in mine_m:
        if c.spine in BASE_COLOURS and c.est is not None:
            col = BASE_COLOURS[c.spine]
            ax.axhline(c.est.value, color=col, lw=1.3, label=f"{c.spine} (n={c.est.n_seeds})")
            if c.est.lo is not None:
                ax.axhspan(c.est.lo, c.est.hi, color=col, alpha=0.25, zorder=0)
    ds = sorted({c.d for c in mine_m if c.spine == spine and c.d is not None}) or [None]
    top = max((max(c.est.per_seed) for c in mine_m if c.est is not None and c.est.per_seed), default=1.0)
    for i_d, d in enumerate(ds):
        cs = sorted(
            (c for c in mine_m if c.spine == spine and c.d == d and c.k is not None), key=lambda c: c.k
        )
        if not cs:
            continue
        dodge = 1.0 + 0.015 * (i_d - (len(ds) - 1) / 2)
        colour = None
        run: list = []  # consecutive cells with an estimate: a line never crosses a fully fallen cell
        for c in [*cs, None]:
            if c is not None and c.est is not None:
                run.append(c)
                continue
            if run:
                x = np.array([r.k for r in run]) * dodge
                y = np.array([r.est.value for r in run])
                lo = np.array([r.est.lo if r.est.lo is not None else r.est.value for r in run])
                hi = np.array([r.est.hi if r.est.hi is not None else r.est.value for r in run])
                h = ax.errorbar(
                    x,
                    y,
                    yerr=[y - lo, hi - y],
                    marker="o",
                    capsize=3,
                    color=colour,
                    label=f"d_x {_fmt(d, 0)} N·s/m" if colour is None else None,
                )
                colour = h[0].get_color()
                for r, xx in zip(run, x, strict=True):
                    ax.plot([xx] * len(r.est.per_seed), r.est.per_seed, ".", ms=3, color=colour, alpha=0.5)
                    if r.off_speed:
                        ax.plot(xx, r.est.value, "o", ms=11, mfc="none", mec="k")
                run = []
            if c is not None:  # every trial fell: drawn as fallen at the top, not joined
                ax.plot(c.k * dodge, top, "X", ms=10, color=colour or "tab:red")
                ax.annotate("fell", (c.k * dodge, top), fontsize=7, color="tab:red", ha="center", va="bottom")
    ks = sorted({c.k for c in mine_m if c.k is not None})
    ax.set_xticks(
        ks,
        [f"{k:g}\n{fn[k]:.1f} Hz" if k in fn and math.isfinite(fn[k]) else f"{k:g}" for k in ks],
        fontsize=7,
    )
    ax.grid(alpha=0.3)


def plot_vs_k(panel: dict, metric: str, cells: list, fn: dict, path: Path) -> Path | None:
    """CoT against k per d: total, legs, spine (rows) per spine variant (columns)."""
    plt = _plt()
    if not metric.endswith("_total"):
        return None
    stem = metric[: -len("_total")]
    rows = [m for m in (metric, f"{stem}_legs", f"{stem}_spine") if _mine(panel, m, cells)]
    mine = _mine(panel, metric, cells)
    spines = [s for s in _spines(mine) if any(c.spine == s and c.k is not None for c in mine)]
    if not spines:
        return None
    fig, axes = plt.subplots(
        len(rows),
        len(spines),
        figsize=(max(7.0, 5.4 * len(spines)), 3.3 * len(rows)),
        squeeze=False,
        sharex=True,
        constrained_layout=True,
    )
    for i, m in enumerate(rows):
        for j, spine in enumerate(spines):
            ax = axes[i][j]
            _draw_cost(ax, _mine(panel, m, cells), spine, fn)
            if j == 0:
                ax.set_ylabel(label(m), fontsize=8)
            if i == 0:
                ax.set_title(f"{spine} spine", fontsize=10)
                ax.legend(fontsize=7, loc="best")
            if i == len(rows) - 1:
                ax.set_xlabel("k_x (N/m); below: f_n(k), the spine's free-oscillation frequency")
    fig.suptitle(
        f"{panel['panel']}: {label(metric)} against k, legs and spine split\nerror bars 95 % CI over "
        f"seeds, dots per seed, bands the baselines' CI; hollow ring: off-speed; X: every trial fell",
        fontsize=9,
    )
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def plot_frequency(panel: dict, cells: list, fn: dict, path: Path) -> Path | None:
    """Each cell's gait frequency (tuned per cell for raibert-opt, adapted for sine) against f_n(k)."""
    plt = _plt()
    mine = [c for c in _mine(panel, "cot_pos_total", cells) if c.k is not None and c.spine in SPINES]
    pts = [(c.k, c.extras.get("commanded_gait_frequency_hz"), c) for c in mine]
    pts = [p for p in pts if p[1] is not None]
    if not pts or not fn:
        return None
    fig, ax = plt.subplots(figsize=(7, 4), constrained_layout=True)
    kk = np.array(sorted(fn))
    ax.plot(kk, [fn[k] for k in kk], "k--", label="f_n(k) of the spine")
    for spine, marker in zip(SPINES, "os", strict=True):
        sel = [p for p in pts if p[2].spine == spine]
        if sel:
            ax.plot(
                [p[0] for p in sel],
                [p[1] for p in sel],
                marker,
                ls="none",
                alpha=0.7,
                label=f"{spine}: gait frequency per cell",
            )
    _finish(
        fig,
        ax,
        path,
        "k_x (N/m)",
        "frequency (Hz)",
        f"{panel['panel']}: per-cell gait frequency against f_n(k)",
    )
    return path


def plot_cost_vs_speed(panels: list[dict], metric: str, cells: list, path: Path) -> Path | None:
    """Each cell's cost against its mean speed over a family of panels (gait A: one per step length L),
    one colour per spine, one marker per panel: where speed is emergent, cost is compared at equal speed
    here (and the claims compare on-speed cells of any L)."""
    plt = _plt()
    names = [p["panel"] for p in panels]
    mine = [c for c in cells if c.panel in names and c.metric == metric and c.est is not None]
    if not mine:
        return None
    fig, ax = plt.subplots(figsize=(7.5, 4.4), constrained_layout=True)
    colours = {"impedance": "tab:blue", "passive": "tab:green", **BASE_COLOURS}
    markers = dict(zip(names, "osD^v<>p*h", strict=False))
    seen: set[str] = set()
    for c in mine:
        v = c.extras.get("speed_m_s")
        if v is None:
            continue
        ax.plot(
            v,
            c.est.value,
            markers.get(c.panel, "o"),
            color=colours.get(c.spine, "k"),
            mfc="none" if c.off_speed else None,
            ms=8 if c.spine in BASE_COLOURS else 5,
            label=None if c.spine in seen else c.spine,
        )
        seen.add(c.spine)
    t = panels[0].get("target_speed_m_s")
    if t is not None:
        ax.axvspan(t - 0.05, t + 0.05, color="0.9", zorder=0, label="target +- 0.05 m/s")
    values = [c.est.value for c in mine if c.extras.get("speed_m_s") is not None]
    if values and min(values) > 0 and max(values) > 10 * min(values):
        ax.set_yscale("log")  # one slow, expensive cell must not flatten the rest
    step = {p["panel"]: p["config"].get("step_length") for p in panels}
    key = ", ".join(f"{m} L {1000 * step[n]:.0f} mm" if step[n] else f"{m} {n}" for n, m in markers.items())
    _finish(
        fig,
        ax,
        path,
        "mean speed (m/s)",
        label(metric),
        f"{panels[0]['panel'].split('_step_length')[0]}: cost against speed, one point per cell "
        f"(hollow: off-speed)\nmarkers: {key}",
    )
    return path


def _finish(fig, ax, path: Path, xlabel: str, ylabel: str, title: str) -> None:
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    ax.set_title(title, fontsize=8)
    fig.savefig(path, dpi=110)
    _plt().close(fig)


def _families(panels: list[dict]) -> dict[str, list[dict]]:
    """Panels that differ only in the gait's step length, by a file-name stem."""
    out: dict[tuple, list[dict]] = {}
    for p in panels:
        out.setdefault(
            tuple(sorted((k, repr(v)) for k, v in p["config"].items() if k != "step_length")), []
        ).append(p)
    return {fam[0]["panel"].split("_step_length")[0]: fam for fam in out.values()}


def write_plots(res: dict, out: Path, fn: dict, plotted: tuple[str, ...]) -> list[Path]:
    """Every plot of every panel for the metrics in `plotted`, and cost against speed per panel family."""
    paths: list[Path] = []
    for panel in res["panels"]:
        name = panel["panel"]
        for m in [m for m in res["metrics"] if m in plotted]:
            for p in (
                plot_heatmap(panel, m, res["cells"], out / f"heatmap_{name}_{m}.png"),
                plot_vs_k(panel, m, res["cells"], fn, out / f"cot_vs_k_{name}_{m}.png"),
            ):
                if p:
                    paths.append(p)
        p = plot_frequency(panel, res["cells"], fn, out / f"frequency_vs_fn_{name}.png")
        if p:
            paths.append(p)
    for stem, fam in _families(res["panels"]).items():
        for m in [m for m in res["metrics"] if m in plotted]:
            p = plot_cost_vs_speed(fam, m, res["cells"], out / f"cot_vs_speed_{stem}_{m}.png")
            if p:
                paths.append(p)
    return paths
