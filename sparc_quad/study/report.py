"""Study report: per gait x speed x slope ("panel"), the cost of transport over k x d against the rigid
spine, with bootstrap CIs over seeds and strides and differences paired by seed.

Writes DIR/report/: cells.csv and cells.json (every cell, every metric, the rigid baselines, the optimum
per panel), heatmap_<panel>_<metric>.png (% against rigid; hatched where a trial fell or the CI of the
difference contains 0) and cot_vs_k_<panel>_<metric>.png (CoT against k per d, rigid as a band, the
spine's natural frequency f_n(k) against the gait frequency marked).
"""

from __future__ import annotations

import json
import math
import re
from collections import defaultdict
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from sparc_quad.metrics import COTS, GROUPS, TABLE, label
from sparc_quad.study.records import atomic_write_text, jsonable, read_record
from sparc_quad.study.spec import SPINE_GAIN_KEYS
from sparc_quad.study.stats import Estimate, mean_over_seeds, paired_difference, wilson

K_AXIS, D_AXIS = "kx", "dx"
# the costs analysed: the table's whole CoT family (legs, spine, total for pos, abs, net, elec)
METRICS = tuple(f"cot_{c}_{g}" for c in COTS for g in GROUPS)
PLOTTED = ("cot_pos_total", "cot_pos_legs", "cot_abs_total")
EXTRA = ("speed_m_s", "stride_length_m", "stride_frequency_hz")
BASELINES = ("rigid", "rigid-impedance")
if not set(PLOTTED + EXTRA) <= set(TABLE):
    raise ImportError(f"report metrics not in sparc_quad.metrics.TABLE: {set(PLOTTED + EXTRA) - set(TABLE)}")


class ReportError(ValueError):
    """The folder is not a study or holds no usable trials."""


@dataclass
class Trial:
    config: dict
    metrics: dict
    ok: bool
    fell: bool

    def values(self, metric: str) -> list[float]:
        """Per-stride values of `metric` when the strides carry it, else the trial's one value."""
        out = []
        for s in self.metrics.get("strides") or []:
            v = s.get(metric)
            if isinstance(v, int | float) and math.isfinite(v):
                out.append(float(v))
        if out:
            return out
        v = self.metrics.get(metric)
        return (
            [float(v)] if isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v) else []
        )


@dataclass
class Cell:
    panel: str
    spine: str
    k: float | None
    d: float | None
    metric: str
    n: int
    n_fell: int
    fall_rate: float
    fall_lo: float
    fall_hi: float
    est: Estimate | None
    diff_pct: Estimate | None  # against the panel's rigid spine, paired by seed
    extras: dict = field(default_factory=dict)
    seeds: dict = field(default_factory=dict, repr=False)  # seed -> values (pairing against other cells)

    @property
    def hatched(self) -> bool:
        return self.n_fell > 0 or self.diff_pct is None or self.diff_pct.overlaps(0.0)

    def row(self) -> dict:
        e, d = self.est, self.diff_pct
        r = {
            "panel": self.panel,
            "spine": self.spine,
            "k": self.k,
            "d": self.d,
            "metric": self.metric,
            "n": self.n,
            "n_fell": self.n_fell,
            "fall_rate": self.fall_rate,
            "fall_lo": self.fall_lo,
            "fall_hi": self.fall_hi,
            "mean": e.value if e else None,
            "lo": e.lo if e else None,
            "hi": e.hi if e else None,
            "n_seeds": e.n_seeds if e else 0,
            "n_strides": e.n_strides if e else 0,
            "diff_pct": d.value if d else None,
            "diff_lo": d.lo if d else None,
            "diff_hi": d.hi if d else None,
            "overlaps_rigid": self.hatched if self.spine not in BASELINES else None,
        }
        for k, v in self.extras.items():
            r[k] = v
        return r


def load_trials(folder: Path) -> tuple[dict, list[Trial]]:
    folder = Path(folder)
    sp = folder / "summary.json"
    if not sp.is_file():
        raise ReportError(f"{folder}: no summary.json (not a folder written by `sparc-quad study run`)")
    try:
        summary = json.loads(sp.read_text())
        hashes = list(summary["hashes"])
    except (ValueError, KeyError, TypeError) as exc:
        raise ReportError(f"{sp}: unreadable ({exc})") from None
    trials = []
    for h in hashes:
        rec = read_record(folder / "trials" / f"{h}.json")
        if rec is None:
            continue
        m = rec.get("metrics") or {}
        ok = rec["status"] == "ok"
        trials.append(Trial(rec["config"], m, ok, bool(m.get("fell", False)) if ok else False))
    if not any(t.ok for t in trials):
        raise ReportError(f"{folder}: no successful trials among {len(hashes)} planned")
    return summary, trials


def panel_key(cfg: dict) -> tuple:
    """What a heatmap holds fixed: everything but the seed, the spine variant and its gains."""
    return tuple(sorted((k, v) for k, v in cfg.items() if k not in ("seed", "spine", *SPINE_GAIN_KEYS)))


def panel_name(key: tuple, varied: set[str]) -> str:
    d = dict(key)
    parts = [str(d.get("gait", ""))]
    if "speed" in d:
        parts.append(f"{d['speed']:g}mps")
    if "slope" in d:
        parts.append(f"slope{d['slope']:g}")
    parts += [f"{k}{v}" for k, v in key if k in varied and k not in ("gait", "speed", "slope")]
    return re.sub(r"[^A-Za-z0-9_.+-]", "_", "_".join(parts))


def _by_seed(trials: Iterable[Trial], metric: str) -> dict[int, list[float]]:
    out: dict[int, list[float]] = {}
    for t in trials:
        if t.ok and not t.fell:
            v = t.values(metric)
            if v:
                out[int(t.config.get("seed", 0))] = v
    return out


def _extras(trials: list[Trial], n_boot: int) -> dict:
    out = {}
    for name in EXTRA:
        e = mean_over_seeds(list(_by_seed(trials, name).values()), n_boot=n_boot)
        out[name] = e.value if e else None
    return out


def analyse(trials: list[Trial], n_boot: int = 2000) -> dict:
    """All cells of all panels, the rigid baselines and the optimum per (panel, spine, metric)."""
    ok = [t for t in trials if t.ok]
    varied = {k for k in {k for t in ok for k in t.config} if len({repr(t.config.get(k)) for t in ok}) > 1}
    groups: dict[tuple, dict[tuple, list[Trial]]] = defaultdict(lambda: defaultdict(list))
    for t in ok:
        cfg = t.config
        spine = cfg.get("spine", "impedance")
        gains = tuple(
            sorted((k, v) for k, v in cfg.items() if k in SPINE_GAIN_KEYS and k not in (K_AXIS, D_AXIS))
        )
        groups[panel_key(cfg)][(spine, gains, cfg.get(K_AXIS), cfg.get(D_AXIS))].append(t)
    # a metric the trials report (even as NaN after a fall), so cells that all fell still show their falls
    metrics = [m for m in METRICS if any(m in t.metrics for t in ok)]
    cells: list[Cell] = []
    panels = []
    for pkey in sorted(groups, key=repr):
        name = panel_name(pkey, varied)
        cellmap = groups[pkey]
        base_spine = next((b for b in BASELINES if any(c[0] == b for c in cellmap)), None)
        base_trials = [t for c, ts in cellmap.items() if c[0] == base_spine for t in ts] if base_spine else []
        gait_f = [
            t.metrics.get("commanded_gait_frequency_hz", t.metrics.get("gait_frequency_hz"))
            for ts in cellmap.values()
            for t in ts
        ]
        gait_f = [f for f in gait_f if isinstance(f, int | float) and math.isfinite(f)]
        panels.append(
            {
                "panel": name,
                "config": dict(pkey),
                "baseline": base_spine,
                "gait_frequency_hz": float(np.mean(gait_f)) if gait_f else None,
            }
        )
        for (spine, gains, k, d), ts in sorted(cellmap.items(), key=lambda kv: repr(kv[0])):
            nf = sum(t.fell for t in ts)
            rate, lo, hi = wilson(nf, len(ts))
            extras = _extras(ts, n_boot)
            if gains:
                extras["other_gains"] = json.dumps(dict(gains))
            for m in metrics:
                seeds = _by_seed(ts, m)
                est = mean_over_seeds(list(seeds.values()), n_boot=n_boot)
                diff = None
                if base_trials and spine != base_spine:
                    diff = paired_difference(seeds, _by_seed(base_trials, m), n_boot=n_boot)
                cells.append(Cell(name, spine, k, d, m, len(ts), nf, rate, lo, hi, est, diff, extras, seeds))
    return {"panels": panels, "metrics": metrics, "cells": cells, "optima": optima(cells, n_boot)}


def optima(cells: list[Cell], n_boot: int = 2000) -> list[dict]:
    """Per (panel, spine, metric) over k x d: the lowest mean among cells where nothing fell, and the
    cells not distinguishable from it (their difference to it, paired by seed, has a CI reaching 0)."""
    out = []
    key = defaultdict(list)
    for c in cells:
        if c.spine not in BASELINES:
            key[(c.panel, c.spine, c.metric)].append(c)
    for (panel, spine, metric), cs in key.items():
        # a cell that falls more often is worse whatever its CoT: rank CoT among the cells with the fewest
        # falls (their CoT over the seeds that did not fall)
        rated = [c for c in cs if c.est is not None]
        fewest = min((c.n_fell / c.n for c in rated), default=None)
        good = [c for c in rated if c.n_fell / c.n == fewest]
        if not good:
            out.append({"panel": panel, "spine": spine, "metric": metric, "best": None})
            continue
        best = min(good, key=lambda c: c.est.value)
        near = []
        for c in good:
            diff = None if c is best else paired_difference(c.seeds, best.seeds, n_boot=n_boot)
            if c is best or diff is None or diff.overlaps(0.0) or (diff.lo is not None and diff.lo <= 0.0):
                near.append(c)
        out.append(
            {
                "panel": panel,
                "spine": spine,
                "metric": metric,
                "best": best.row(),
                "near_best": [{"k": c.k, "d": c.d, "mean": c.est.value} for c in near],
                "near_best_k": sorted({c.k for c in near if c.k is not None}),
                "near_best_d": sorted({c.d for c in near if c.d is not None}),
            }
        )
    return out


def natural_frequencies(ks: Iterable[float], cache: Path) -> dict[float, float]:
    """f_n(k) from the free-oscillation test (sparc_quad.sim.spine_resonance), cached in `cache`."""
    have: dict[str, float] = {}
    if cache.is_file():
        try:
            have = json.loads(cache.read_text())
        except ValueError:
            have = {}
    try:
        from sparc_quad.sim.spine_resonance import spine_natural_frequency_hz
    except ImportError:
        return {float(k): v for k, v in have.items()}
    out = {}
    for k in ks:
        key = f"{float(k):g}"
        if key not in have:
            have[key] = float(spine_natural_frequency_hz(float(k)))
        out[float(k)] = have[key]
    atomic_write_text(cache, json.dumps(have, indent=1) + "\n")
    return out


def _fmt(x: float | None, nd: int = 2) -> str:
    return "–" if x is None or not math.isfinite(x) else f"{x:.{nd}f}"


def _label(metric: str) -> str:
    return label(metric)


def plot_heatmap(panel: dict, metric: str, cells: list[Cell], path: Path) -> Path | None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.colors import TwoSlopeNorm
    from matplotlib.patches import Rectangle

    mine = [c for c in cells if c.panel == panel["panel"] and c.metric == metric]
    base = next((c for c in mine if c.spine == panel["baseline"]), None)
    spines = [s for s in ("impedance", "passive") if any(c.spine == s for c in mine)]
    spines += sorted({c.spine for c in mine} - set(spines) - set(BASELINES))
    if not spines:
        return None
    ks = sorted({c.k for c in mine if c.spine in spines and c.k is not None})
    ds = sorted({c.d for c in mine if c.spine in spines and c.d is not None})
    ks, ds = ks or [None], ds or [None]
    diffs = [abs(c.diff_pct.value) for c in mine if c.diff_pct is not None]
    # colours saturate at +-40 %: a few failed cells must not wash out the differences that matter
    lim = float(np.clip(max(diffs, default=10.0), 10.0, 40.0))
    norm = TwoSlopeNorm(vmin=-lim, vcenter=0.0, vmax=lim)
    fig, axes = plt.subplots(
        1,
        len(spines),
        figsize=(max(7.0, 1.9 * len(ks) * len(spines) + 1.8), 1.15 * len(ds) + 2.6),
        squeeze=False,
        constrained_layout=True,
    )
    im = None
    for ax, spine in zip(axes[0], spines, strict=True):
        grid = np.full((len(ds), len(ks)), np.nan)
        for c in mine:
            if c.spine != spine:
                continue
            i, j = ds.index(c.d), ks.index(c.k)
            if c.diff_pct is not None:
                grid[i, j] = c.diff_pct.value
            im = ax.imshow(grid, cmap="RdBu_r", norm=norm, origin="lower", aspect="auto")
        for c in mine:
            if c.spine != spine:
                continue
            i, j = ds.index(c.d), ks.index(c.k)
            lines = [f"{_fmt(c.est.value if c.est else None)}"]
            if c.diff_pct is not None:
                d = c.diff_pct
                lines.append(f"{d.value:+.0f}% [{_fmt(d.lo, 0)},{_fmt(d.hi, 0)}]")
            v = c.extras.get("speed_m_s")
            if v is not None:
                lines.append(f"{v:.2f} m/s")
            if c.n_fell:
                lines.append(f"fell {c.n_fell}/{c.n}")
            dark = c.diff_pct is not None and abs(c.diff_pct.value) > 0.6 * lim
            ax.text(j, i, "\n".join(lines), ha="center", va="center", fontsize=8, color="w" if dark else "k")
            if c.hatched:
                hatch = ("xx" if c.n_fell else "") + (
                    "///" if c.diff_pct is None or c.diff_pct.overlaps(0.0) else ""
                )
                ax.add_patch(
                    Rectangle((j - 0.5, i - 0.5), 1, 1, fill=False, hatch=hatch, edgecolor="0.45", lw=0)
                )
        ax.set_xticks(range(len(ks)), [_fmt(k, 0) for k in ks])
        ax.set_yticks(range(len(ds)), [_fmt(d, 0) for d in ds])
        ax.set_xlabel("k_x (N/m)")
        ax.set_ylabel("d_x (N·s/m)")
        ax.set_title(f"{spine} spine", fontsize=10)
    if im is not None:
        cb = fig.colorbar(im, ax=axes[0].tolist(), shrink=0.9, extend="both")
        cb.set_label(f"% against {panel['baseline'] or 'rigid'} (blue = cheaper)")
    btxt = (
        f"{panel['baseline']} {_fmt(base.est.value)} [{_fmt(base.est.lo)}, {_fmt(base.est.hi)}] at "
        f"{_fmt(base.extras.get('speed_m_s'))} m/s"
        if base and base.est
        else "no rigid baseline"
    )
    fig.suptitle(
        f"{panel['panel']}: {_label(metric)}\n{btxt}\ncell: mean, % vs rigid [95 % CI], mean speed; "
        "hatched: xx a trial fell, /// the CI of the difference contains 0",
        fontsize=9,
    )
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def plot_vs_k(panel: dict, metric: str, cells: list[Cell], fn: dict[float, float], path: Path) -> Path | None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    mine = [c for c in cells if c.panel == panel["panel"] and c.metric == metric and c.est is not None]
    base = next((c for c in mine if c.spine == panel["baseline"]), None)
    spines = [s for s in ("impedance", "passive") if any(c.spine == s and c.k is not None for c in mine)]
    if not spines:
        return None
    fig, axes = plt.subplots(
        1,
        len(spines),
        figsize=(max(7.0, 5.2 * len(spines)), 4.4),
        squeeze=False,
        sharey=True,
        constrained_layout=True,
    )
    ks_all = sorted({c.k for c in mine if c.k is not None})
    gf = panel.get("gait_frequency_hz")
    for ax, spine in zip(axes[0], spines, strict=True):
        if base is not None:
            ax.axhline(base.est.value, color="k", lw=1.2, label=f"{base.spine}")
            if base.est.lo is not None:
                ax.axhspan(base.est.lo, base.est.hi, color="0.85", zorder=0)
        ds = sorted({c.d for c in mine if c.spine == spine and c.d is not None}) or [None]
        for i_d, d in enumerate(ds):
            cs = sorted(
                (c for c in mine if c.spine == spine and c.d == d and c.k is not None), key=lambda c: c.k
            )
            if not cs:
                continue
            x = np.array([c.k for c in cs]) * (1.0 + 0.012 * (i_d - (len(ds) - 1) / 2))  # dodge the d lines
            y = np.array([c.est.value for c in cs])
            lo = np.array([c.est.lo if c.est.lo is not None else c.est.value for c in cs])
            hi = np.array([c.est.hi if c.est.hi is not None else c.est.value for c in cs])
            line = ax.errorbar(
                x, y, yerr=[y - lo, hi - y], marker="o", capsize=3, label=f"d_x {_fmt(d, 0)} N·s/m"
            )
            fell = [c for c in cs if c.n_fell]
            if fell:
                ax.plot(
                    [c.k for c in fell], [c.est.value for c in fell], "x", ms=10, color=line[0].get_color()
                )
        if fn and gf:
            kk = np.array(sorted(fn))
            ff = np.array([fn[k] for k in kk])
            good = np.isfinite(ff)
            if good.sum() >= 2 and ff[good].min() <= gf <= ff[good].max():
                k_res = float(np.interp(gf, ff[good], kk[good]))  # f_n rises with k
                ax.axvline(k_res, ls="--", color="tab:red", lw=1)
                ax.text(
                    k_res,
                    ax.get_ylim()[1],
                    f" f_n = f_gait\n {gf:.2f} Hz",
                    color="tab:red",
                    va="top",
                    fontsize=8,
                )
        ax.set_xticks(
            ks_all,
            [f"{k:g}\nf_n {fn[k]:.1f} Hz" if k in fn and math.isfinite(fn[k]) else f"{k:g}" for k in ks_all],
            fontsize=8,
        )
        ax.set_xlabel("k_x (N/m); f_n(k) the spine's free-oscillation frequency")
        ax.set_title(f"{spine} spine", fontsize=10)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8, loc="best")
    axes[0][0].set_ylabel(_label(metric))
    gtxt = f"gait {gf:.2f} Hz" if gf else ""
    fig.suptitle(
        f"{panel['panel']}: {_label(metric)} against k\n{gtxt}; error bars and grey band (rigid): 95 % CI; "
        "x: a trial fell",
        fontsize=9,
    )
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def load_studies(folders: list[Path]) -> tuple[dict, list[Trial]]:
    """Several study folders as one (e.g. a full grid at one speed and a cheaper one at another)."""
    summaries, trials = [], []
    for f in folders:
        s, t = load_trials(f)
        summaries.append(s)
        trials += t
    if len(summaries) == 1:
        return summaries[0], trials
    merged = {
        "name": "+".join(str(s.get("name")) for s in summaries),
        "code_version": sorted({str(s.get("code_version")) for s in summaries}),
        "trials": sum(int(s.get("trials") or 0) for s in summaries),
        "studies": [str(f) for f in folders],
    }
    return merged, trials


def write_report(folder: Path | list[Path], n_boot: int = 2000, out: Path | None = None) -> list[Path]:
    """Report on one study folder (into DIR/report) or several merged (into `out`)."""
    folders = [Path(f) for f in (folder if isinstance(folder, list | tuple) else [folder])]
    summary, trials = load_studies(folders)
    res = analyse(trials, n_boot=n_boot)
    out = Path(out) if out is not None else folders[0] / "report"
    out.mkdir(parents=True, exist_ok=True)
    paths: list[Path] = []
    rows = [c.row() for c in res["cells"]]
    import csv
    import io

    cols: list[str] = []
    for r in rows:
        cols += [k for k in r if k not in cols]
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=cols)
    w.writeheader()
    for r in rows:
        w.writerow({k: "" if r.get(k) is None else r.get(k) for k in cols})
    atomic_write_text(out / "cells.csv", buf.getvalue())
    paths.append(out / "cells.csv")
    ks = sorted({c.k for c in res["cells"] if c.k is not None})
    fn = natural_frequencies(ks, out / "natural_frequency.json") if ks else {}
    doc = {
        "study": summary.get("name"),
        "code_version": summary.get("code_version"),
        "trials": summary.get("trials"),
        "done": len(trials),
        "failed": sum(not t.ok for t in trials),
        "fell": sum(t.fell for t in trials),
        "n_bootstrap": n_boot,
        "panels": res["panels"],
        "natural_frequency_hz": {f"{k:g}": v for k, v in fn.items()},
        "optima": res["optima"],
        "cells": rows,
    }
    atomic_write_text(out / "cells.json", json.dumps(jsonable(doc), indent=1, allow_nan=False) + "\n")
    paths.append(out / "cells.json")
    from sparc_quad.study.claims import evaluate, markdown

    claims = evaluate(res)
    atomic_write_text(out / "claims.json", json.dumps(jsonable(claims), indent=1, allow_nan=False) + "\n")
    atomic_write_text(out / "claims.md", markdown(claims))
    paths += [out / "claims.json", out / "claims.md"]
    for panel in res["panels"]:
        for m in [m for m in res["metrics"] if m in PLOTTED]:
            p = plot_heatmap(panel, m, res["cells"], out / f"heatmap_{panel['panel']}_{m}.png")
            if p:
                paths.append(p)
            p = plot_vs_k(panel, m, res["cells"], fn, out / f"cot_vs_k_{panel['panel']}_{m}.png")
            if p:
                paths.append(p)
    return paths
