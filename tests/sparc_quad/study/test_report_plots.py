"""The report's plots as a referee reads them, checked on the figure objects: a heatmap's colours clipped
at the 5-95 % quantiles (one extreme cell does not flatten the rest), a positive cost's interval never
below 0, titles and legends inside the figure, and the baselines on every panel of the cost and frequency
plots."""

from __future__ import annotations

import json

import numpy as np
import pytest

from sparc_quad.study.records import write_record
from sparc_quad.study.report import analyse, load_trials
from sparc_quad.study.report_plots import (
    colour_limit,
    cost_vs_speed_figure,
    frequency_figure,
    heatmap_figure,
    positive_interval,
    vs_k_figure,
)
from sparc_quad.study.stats import Estimate

KS = (300.0, 500.0, 800.0, 1200.0, 1600.0, 2000.0)
DS = (2.0, 8.0, 20.0)  # 18 cells: the 95 % quantile lies below the one outlier
# fixed factors (not in the panel name, which names only what varies: the titles' length comes from text)
LONG = {"engine": "mujoco", "host": "spined-dog", "variant": "authors", "duration": 12.0, "slope": 0.0}


def seed_values(spine: str, k: float | None, d: float | None) -> list[float]:
    """Per-seed CoT_pos: baselines about 1; impedance cells near 0.8, except k 2000 d 20, which costs 6.5
    (about +460 % against rigid-impedance, the outlier), and k 300 d 8, nine seeds at 0.1 and one at 10
    (a skewed cell whose t interval reaches below 0)."""
    if spine == "rigid":
        return [1.0 + 0.02 * s for s in range(10)]
    if spine == "rigid-impedance":
        return [1.1 + 0.02 * s for s in range(10)]
    if (k, d) == (2000.0, 20.0):
        return [6.5 * (1.0 + 0.01 * s) for s in range(10)]
    if (k, d) == (300.0, 8.0):
        return [0.1] * 9 + [10.0]
    return [(0.75 + 0.0001 * k + 0.002 * d) * (1.0 + 0.01 * s) for s in range(10)]


def study(folder):
    hashes = []
    cells = [("rigid", None, None), ("rigid-impedance", None, None)]
    cells += [("impedance", k, d) for k in KS for d in DS]
    for spine, k, d in cells:
        for seed, v in enumerate(seed_values(spine, k, d)):
            cfg = {"gait": "sine", "spine": spine, "speed": 0.9, "step_length": 0.08, "seed": seed, **LONG}
            if k is not None:
                cfg.update(kx=k, dx=d)
            m = {"fell": False, "speed_m_s": 0.9, "cot_pos_total": v, "cot_pos_legs": 0.9 * v,
                 "cot_pos_spine": 0.1 * v, "commanded_gait_frequency_hz": 3.0 if k is None else 3.1}
            h = f"h{len(hashes):04d}"
            write_record(folder / "trials", {"hash": h, "config": cfg, "status": "ok", "metrics": m})
            hashes.append(h)
    (folder / "summary.json").write_text(json.dumps({"name": "plots", "hashes": hashes}))
    return analyse(load_trials(folder)[1], n_boot=50)


@pytest.fixture(scope="module")
def res(tmp_path_factory):
    return study(tmp_path_factory.mktemp("plots"))


def _inside(fig) -> None:
    """Every title, suptitle, axis label, legend and colourbar label lies inside the figure."""
    fig.canvas.draw()
    r = fig.canvas.get_renderer()
    box = fig.bbox
    arts = [fig._suptitle] if fig._suptitle is not None else []
    for ax in fig.axes:
        arts += [ax.title, ax.xaxis.label, ax.yaxis.label]
        if ax.get_legend() is not None:
            arts.append(ax.get_legend())
    for a in arts:
        if a is None or (hasattr(a, "get_text") and not a.get_text()):
            continue
        e = a.get_window_extent(r)
        what = a.get_text() if hasattr(a, "get_text") else a
        assert e.x0 >= box.x0 - 1 and e.y0 >= box.y0 - 1 and e.x1 <= box.x1 + 1 and e.y1 <= box.y1 + 1, (
            what, e, box)


def test_positive_interval_of_a_positive_mean_stays_positive():
    e = Estimate(0.5, -0.3, 1.3, 10, 10)  # a t interval reaching below 0
    lo, hi = positive_interval(e)
    assert 0 < lo < 0.5 < hi and lo * hi == pytest.approx(0.25)  # symmetric on the log scale
    assert positive_interval(Estimate(0.0, -1.0, 1.0, 10, 10)) is None
    assert positive_interval(Estimate(0.5, None, None, 1, 1)) is None
    lo, hi = positive_interval(Estimate(1.0, 0.98, 1.02, 10, 10))  # narrow: nearly the t interval
    assert lo == pytest.approx(0.98, abs=4e-4) and hi == pytest.approx(1.02, abs=4e-4)


def test_cost_intervals_drawn_stay_above_zero(res):
    skew = next(c for c in res["cells"] if (c.k, c.d, c.metric) == (300.0, 8.0, "cot_pos_total"))
    assert skew.est.lo < 0  # the t interval of this positive cost reaches below 0: the plot must not
    panel = res["panels"][0]
    fig = vs_k_figure(panel, "cot_pos_total", res["cells"], {})
    lows = []
    for ax in fig.axes:
        for cont in ax.containers:
            for coll in cont.lines[2]:
                lows += [float(np.min(np.asarray(seg)[:, 1])) for seg in coll.get_segments()]
        for patch in ax.patches:  # the baselines' bands (axhspan)
            y = patch.get_bbox().y0 if hasattr(patch, "get_bbox") else float(np.min(patch.get_xy()[:, 1]))
            lows.append(y)
    assert lows and min(lows) > 0, min(lows)


def test_heatmap_colours_clip_at_the_5_95_quantiles(res):
    panel = res["panels"][0]
    diffs = [c.diff_pct.value for c in res["cells"] if c.metric == "cot_pos_total" and c.diff_pct is not None
             and c.spine == "impedance"]
    assert max(diffs) > 400  # the outlier cell
    q = np.quantile(diffs, [0.05, 0.95])
    want = max(5.0, float(np.max(np.abs(q))))
    assert colour_limit(diffs) == (want, sum(abs(d) > want for d in diffs))
    fig = heatmap_figure(panel, "cot_pos_total", res["cells"])
    norm = fig.axes[0].images[0].norm
    assert (norm.vmin, norm.vmax) == (pytest.approx(-want), pytest.approx(want)) and want < 0.5 * max(diffs)
    bar = next(ax for ax in fig.axes if ax.get_gid() == "colourbar")
    assert "clipped" in bar.get_ylabel() and "5" in bar.get_ylabel() and "95 % quantiles" in bar.get_ylabel()
    _inside(fig)


def test_titles_and_legends_inside_every_figure(res):
    panel = res["panels"][0]
    for fig in (
        vs_k_figure(panel, "cot_pos_total", res["cells"], {}),
        frequency_figure(panel, res["cells"], {k: 4.0 for k in KS}),
        cost_vs_speed_figure(res["panels"], "cot_pos_total", res["cells"]),
    ):
        assert fig is not None
        _inside(fig)


def test_baselines_on_every_panel_of_the_cost_and_frequency_plots(res):
    panel = res["panels"][0]
    for fig in (
        vs_k_figure(panel, "cot_pos_total", res["cells"], {}),
        frequency_figure(panel, res["cells"], {k: 4.0 for k in KS}),
    ):
        for ax in fig.axes:
            gids = {a.get_gid() for a in ax.get_children()}
            assert {"baseline:rigid", "baseline:rigid-impedance"} <= gids, ax.get_title()
