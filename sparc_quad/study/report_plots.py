"""The study report's plots, from `report.analyse`'s cells (matplotlib, Agg).

Read at a glance: per-seed points beside each cell's mean and interval, the seed count, off-speed cells
marked (hollow / dotted), fully fallen cells drawn as fallen (never interpolated over), the baselines on
every panel, legs and spine split, and each cell's gait frequency against the spine's f_n(k).

Made for a referee: a heatmap's colours are clipped at the 5-95 % quantiles of its cells' values (one
extreme cell must not flatten the rest; the colourbar says so, each cell prints its own value); a cost's
interval is drawn on the log scale (`positive_interval`), so a positive cost never shows a negative bound;
titles are wrapped to the figure's width and every figure is laid out so its titles and legends stay
inside it (`tests/sparc_quad/study/test_report_plots.py`). Each plot is built by a `*_figure` function
(testable) and saved by `plot_*`.
"""

from __future__ import annotations

import json
import math
import textwrap
from collections.abc import Iterable
from pathlib import Path

import numpy as np

from sparc_quad.metrics import label
from sparc_quad.study.records import atomic_write_text

SPINES = ("impedance", "passive")
BASE_COLOURS = {"rigid": "0.35", "rigid-impedance": "tab:purple"}
CLIP_QUANTILES = (0.05, 0.95)  # a heatmap's colour scale spans these quantiles of its cells' values
MIN_COLOUR_LIMIT_PCT = 5.0  # a panel of near-equal cells is not stretched to look different
DPI = 110


def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _fmt(x: float | None, nd: int = 2) -> str:
    return "–" if x is None or not math.isfinite(x) else f"{x:.{nd}f}"


def _wrap(text: str, fig, fontsize: float) -> str:
    """Text wrapped to the figure's width (an unwrapped long panel name runs off the figure)."""
    chars = max(20, int(fig.get_figwidth() * 72 / (0.62 * fontsize)))
    return "\n".join(textwrap.fill(line, chars, break_on_hyphens=False) for line in text.split("\n"))


def _save(fig, path: Path) -> Path:
    fig.savefig(path, dpi=DPI, bbox_inches="tight", pad_inches=0.05)
    _plt().close(fig)
    return path


def colour_limit(values: Iterable[float]) -> tuple[float, int]:
    """The heatmap's symmetric colour limit: the larger magnitude of the 5 % and 95 % quantiles of the
    values (at least MIN_COLOUR_LIMIT_PCT), and how many values lie beyond it (drawn in the end colour)."""
    v = np.array([x for x in values if x is not None and math.isfinite(x)], dtype=float)
    if not v.size:
        return MIN_COLOUR_LIMIT_PCT, 0
    q = np.quantile(v, CLIP_QUANTILES)
    lim = max(MIN_COLOUR_LIMIT_PCT, float(np.max(np.abs(q))))
    return lim, int(np.sum(np.abs(v) > lim))


def positive_interval(e) -> tuple[float, float] | None:
    """A positive mean's 95 % interval on the log scale: mean x/÷ exp(h / mean), h the half-width of its
    t interval (the delta method, SE(log m) = SE(m) / m), so a positive cost never shows a bound below 0;
    None without an interval or for a mean <= 0."""
    if e is None or e.lo is None or e.hi is None or not e.value > 0:
        return None
    f = math.exp((e.hi - e.value) / e.value)
    return e.value / f, e.value * f


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
    fig = heatmap_figure(panel, metric, cells)
    return _save(fig, path) if fig is not None else None


def heatmap_figure(panel: dict, metric: str, cells: list):
    """% against each cell's baseline over k x d, one panel per spine; colours clipped at the 5-95 %
    quantiles of the cells' values (`colour_limit`), said on the colourbar."""
    plt = _plt()
    from matplotlib.colors import TwoSlopeNorm
    from matplotlib.patches import Rectangle

    mine = _mine(panel, metric, cells)
    spines = _spines(mine)
    if not spines:
        return None
    ks = sorted({c.k for c in mine if c.spine in spines and c.k is not None}) or [None]
    ds = sorted({c.d for c in mine if c.spine in spines and c.d is not None}) or [None]
    lim, n_clipped = colour_limit(
        c.diff_pct.value for c in mine if c.spine in spines and c.diff_pct is not None
    )
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
        bar = fig.colorbar(im, ax=axes[0].tolist(), shrink=0.9, extend="both")
        bar.set_label(
            f"% against the baseline (blue = cheaper)\ncolours clipped at +-{lim:.0f} % (the larger of the 5 "
            f"and 95 % quantiles; {n_clipped} cells beyond)",
            fontsize=8,
        )
        bar.ax.set_gid("colourbar")
    target = panel.get("target_speed_m_s")
    fig.suptitle(
        _wrap(
            f"{panel['panel']}: {label(metric)}; target speed {_fmt(target)} m/s "
            f"({panel.get('target_source')})\n{_baseline_text(mine)}\ncell: mean, % vs baseline [95 % CI], "
            "speed, seeds; hatched xx a "
            "trial fell, /// CI contains 0; dotted box: off target (not judged); dark: every trial fell; "
            f"colours clipped at the 5-95 % quantiles (+-{lim:.0f} %), each cell prints its own value",
            fig,
            8,
        ),
        fontsize=8,
    )
    return fig


def _draw_baselines(ax, base_cells: list, value) -> None:
    """Every baseline of the panel on this axes, so no panel is read without them: a line at its value,
    or, if every trial fell, a labelled note; each artist's gid names the baseline."""
    for c in base_cells:
        col = BASE_COLOURS[c.spine]
        v = value(c)
        if v is None:
            ax.plot([], [], " ", label=f"{c.spine}: fell {c.n_fell}/{c.n}", gid=f"baseline:{c.spine}")
            continue
        n = c.est.n_seeds if c.est is not None else c.n - c.n_fell
        ax.axhline(v, color=col, lw=1.3, ls="-.", label=f"{c.spine} (n={n})", gid=f"baseline:{c.spine}")


def _draw_cost(ax, mine_m: list, spine: str, fn: dict) -> None:
    base = [c for c in mine_m if c.spine in BASE_COLOURS]
    _draw_baselines(ax, base, lambda c: c.est.value if c.est is not None else None)
    for c in base:
        band = positive_interval(c.est)
        if band is not None:
            ax.axhspan(*band, color=BASE_COLOURS[c.spine], alpha=0.25, zorder=0)
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
                bands = [positive_interval(r.est) or (r.est.value, r.est.value) for r in run]
                lo = np.array([b[0] for b in bands])
                hi = np.array([b[1] for b in bands])
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
    fig = vs_k_figure(panel, metric, cells, fn)
    return _save(fig, path) if fig is not None else None


def vs_k_figure(panel: dict, metric: str, cells: list, fn: dict):
    """CoT against k per d: total, legs, spine (rows) per spine variant (columns); the baselines on every
    panel; intervals on the log scale (`positive_interval`)."""
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
            ax.legend(fontsize=6, loc="best")
            if i == len(rows) - 1:
                ax.set_xlabel("k_x (N/m); below: f_n(k), the spine's free-oscillation frequency")
    fig.suptitle(
        _wrap(
            f"{panel['panel']}: {label(metric)} against k, legs and spine split\nerror bars 95 % CI over "
            "seeds on the log scale (mean x/÷ exp(half-width / mean): a cost stays positive), dots per "
            "seed, dash-dot lines and bands the baselines and their CI; hollow ring: off-speed; X: every "
            "trial fell",
            fig,
            9,
        ),
        fontsize=9,
    )
    return fig


def plot_frequency(panel: dict, cells: list, fn: dict, path: Path) -> Path | None:
    fig = frequency_figure(panel, cells, fn)
    return _save(fig, path) if fig is not None else None


def frequency_figure(panel: dict, cells: list, fn: dict):
    """Each cell's gait frequency (tuned per cell for raibert-opt, adapted for sine) against f_n(k), the
    baselines' gait frequencies beside them."""
    plt = _plt()
    everything = _mine(panel, "cot_pos_total", cells)
    mine = [c for c in everything if c.k is not None and c.spine in SPINES]
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
    _draw_baselines(
        ax, [c for c in everything if c.spine in BASE_COLOURS],
        lambda c: c.extras.get("commanded_gait_frequency_hz") if c.est is not None else None,
    )
    _finish(
        fig,
        ax,
        "k_x (N/m)",
        "frequency (Hz)",
        f"{panel['panel']}: per-cell gait frequency against f_n(k); dash-dot: the baselines' gait frequency",
    )
    return fig


def plot_cost_vs_speed(panels: list[dict], metric: str, cells: list, path: Path) -> Path | None:
    fig = cost_vs_speed_figure(panels, metric, cells)
    return _save(fig, path) if fig is not None else None


def cost_vs_speed_figure(panels: list[dict], metric: str, cells: list):
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
        tol = mine[0].speed_tolerance_m_s
        ax.axvspan(t - tol, t + tol, color="0.9", zorder=0, label=f"target +- {tol:.2f} m/s")
    values = [c.est.value for c in mine if c.extras.get("speed_m_s") is not None]
    if values and min(values) > 0 and max(values) > 10 * min(values):
        ax.set_yscale("log")  # one slow, expensive cell must not flatten the rest
    step = {p["panel"]: p["config"].get("step_length") for p in panels}
    key = ", ".join(f"{m} L {1000 * step[n]:.0f} mm" if step[n] else f"{m} {n}" for n, m in markers.items())
    _finish(
        fig,
        ax,
        "mean speed (m/s)",
        label(metric),
        f"{panels[0]['panel'].split('_step_length')[0]}: cost against speed, one point per cell "
        f"(hollow: off-speed; large markers: the baselines)\nmarkers: {key}",
    )
    return fig


def _finish(fig, ax, xlabel: str, ylabel: str, title: str) -> None:
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.legend(fontsize=7, loc="best")
    ax.grid(alpha=0.3)
    ax.set_title(_wrap(title, fig, 8), fontsize=8)


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
        defined = {c.metric for c in res["cells"] if c.panel == name and c.est is not None}
        for m in [m for m in res["metrics"] if m in plotted and m in defined]:  # no CoT_elec, no plot
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
