"""Study report: per panel (everything but seed, spine and its gains fixed) the cost of transport over
k x d against each spine's baseline, with intervals over seeds (sparc_quad.study.stats), differences
paired by seed, matched-speed marks and fall rates compared by their intervals.

Baselines: a motor-rendered spine (impedance) is compared with `rigid-impedance` (the same actuator made
stiff, paying its holding torque), a passive spring-damper with the locked joint (`rigid`); when a panel
lacks the matching one the other is used and the cell says which (`baseline`).

Matched speed: a panel's target is its `speed` (commanded for the Raibert gaits; for the sine gait, whose
speed is emergent, the spec's target, reached or not per cell: over a step-length factor the claims compare
on-speed cells of any L), else its locked baseline's mean speed; a cell whose mean speed is more than
SPEED_TOLERANCE_M_S from it is `off_speed`, left out of best-cell and %-vs-baseline judgements and listed
apart.

Writes DIR/report/: cells.csv and cells.json (every cell, every metric, per-seed values, the optimum per
panel), claims.json/claims.md (sparc_quad.study.claims) and the plots (sparc_quad.study.report_plots).
"""

from __future__ import annotations

import json
import math
import re
from collections import Counter, defaultdict
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from sparc_quad.metrics import COTS, ELEC_SENSITIVITY, GROUPS, TABLE
from sparc_quad.study.best_cell import BASELINE_OF, BASELINES, best_of
from sparc_quad.study.records import atomic_write_text, jsonable, read_record
from sparc_quad.study.report_plots import natural_frequencies, write_plots
from sparc_quad.study.spec import SPINE_GAIN_KEYS
from sparc_quad.study.stats import Estimate, mean_over_seeds, paired_difference, wilson

K_AXIS, D_AXIS = "kx", "dx"
# metrics a trial contributes as one value over its judged window (the estimand), never as a stride mean
WINDOW_METRICS = frozenset(name for name in TABLE if name.startswith("cot_"))
# the costs analysed: the table's CoT family (legs, spine, total) and CoT_elec's sensitivity totals
METRICS = (*(f"cot_{c}_{g}" for c in COTS for g in GROUPS), *(f"cot_{c}_total" for c in ELEC_SENSITIVITY))
PLOTTED = ("cot_pos_total", "cot_elec_total")
EXTRA = (
    "speed_m_s",
    "stride_length_m",
    "stride_frequency_hz",
    "commanded_gait_frequency_hz",
    "spine_torque_rms_nm",
    "peak_spine_torque_nm",
    "spine_saturation_share",
    "leg_saturation_share",
)
if not set(METRICS + EXTRA) <= set(TABLE):
    raise ImportError(f"report metrics not in sparc_quad.metrics.TABLE: {set(METRICS + EXTRA) - set(TABLE)}")
SPEED_TOLERANCE_M_S = 0.05  # emergent speed (gait A): the band about the panel's target
# a commanded speed: a cell that misses its command by more than this is not judged
COMMANDED_SPEED_TOLERANCE_M_S = 0.03
MATCHED = "matched: the cell's input calibrated to run it (speed_match)"


class ReportError(ValueError):
    """The folder is not a study or holds no usable trials."""


@dataclass
class Trial:
    config: dict
    metrics: dict
    ok: bool
    fell: bool

    def values(self, metric: str) -> list[float]:
        """The trial's values of `metric`: for a cost (CoT_*, WINDOW_METRICS) its one value over the judged
        window, energy over the window / (m g x net forward distance), the estimand (a mean of per-stride
        ratios is biased: a near-zero stride's ratio outweighs whole strides; a trial that went backwards
        has no cost of transport); for the others the per-stride values when the strides carry them (the
        within-trial variance of the interval), else the trial's one value."""
        out = []
        for s in ([] if metric in WINDOW_METRICS else self.metrics.get("strides") or []):
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
    diff_pct: Estimate | None  # against `baseline`, paired by seed
    extras: dict = field(default_factory=dict)
    seeds: dict = field(default_factory=dict, repr=False)  # seed -> values (pairing against other cells)
    baseline: str | None = None
    target_speed_m_s: float | None = None
    speed_tolerance_m_s: float = SPEED_TOLERANCE_M_S

    @property
    def all_fell(self) -> bool:
        return self.est is None and self.n_fell == self.n

    @property
    def off_speed(self) -> bool:
        v, t = self.extras.get("speed_m_s"), self.target_speed_m_s
        return v is not None and t is not None and abs(v - t) > self.speed_tolerance_m_s

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
            "interval": e.method if e else None,
            "baseline": self.baseline,
            "diff_pct": d.value if d else None,
            "diff_lo": d.lo if d else None,
            "diff_hi": d.hi if d else None,
            "overlaps_baseline": self.hatched if self.spine not in BASELINES else None,
            "target_speed_m_s": self.target_speed_m_s,
            "off_speed": self.off_speed,
            "per_seed": {str(s): float(np.mean(v)) for s, v in sorted(self.seeds.items())},
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
        plain = folder / "trials" / f"{h}.json"
        rec = read_record(plain if plain.exists() else plain.with_name(f"{h}.json.gz"))  # committed: gzip
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
    if "match_speed" in d:
        parts.append(f"matched{d['match_speed']:g}mps")
    if "slope" in d:
        parts.append(f"slope{d['slope']:g}")
    parts += [f"{k}{v}" for k, v in key if k in varied and k not in ("gait", "speed", "slope")
              and not k.startswith("match_")]  # the calibration's settings are in the spec, not the name
    return re.sub(r"[^A-Za-z0-9_.+-]", "_", "_".join(parts))


def _by_seed(trials: Iterable[Trial], metric: str) -> dict[int, list[float]]:
    out: dict[int, list[float]] = {}
    for t in trials:
        if t.ok and not t.fell:
            v = t.values(metric)
            if v:
                out[int(t.config.get("seed", 0))] = v
    return out


def _extras(trials: list[Trial]) -> dict:
    out = {}
    for name in EXTRA:
        e = mean_over_seeds(list(_by_seed(trials, name).values()))
        out[name] = e.value if e else None
    return out


def _baseline_for(spine: str, present: set[str]) -> str | None:
    if spine in BASELINES:
        return None
    want = BASELINE_OF.get(spine, "rigid")
    return want if want in present else next((b for b in BASELINES if b in present), None)


def panel_target(config: dict, base_speed: float | None) -> tuple[float | None, str]:
    """The speed a panel's cells are judged at, and where it comes from: the commanded speed, or for the
    sine gait (speed emergent) the spec's `speeds` label, else the locked baseline's mean speed; a
    matched-speed study's target (`match_speed`), which every cell was calibrated to run."""
    if isinstance(config.get("match_speed"), int | float):  # the input calibrated per cell (speed_match)
        return float(config["match_speed"]), MATCHED
    if isinstance(config.get("speed"), int | float):
        how = "commanded" if config.get("gait") != "sine" else "the spec's target (speed emergent)"
        return float(config["speed"]), how
    if base_speed is not None:
        return base_speed, "emergent: the baseline's mean speed"
    return None, "emergent, no baseline"


def analyse(trials: list[Trial], n_boot: int = 400) -> dict:
    """All cells of all panels, the baselines and the optimum per (panel, spine, metric)."""
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
        present = {c[0] for c in cellmap}
        # a baseline every trial of which fell cannot be compared with: the other one is used (and named)
        standing = {c[0] for c, ts in cellmap.items() if c[0] in BASELINES and any(not t.fell for t in ts)}
        base_trials = {b: [t for c, ts in cellmap.items() if c[0] == b for t in ts] for b in BASELINES}
        locked = base_trials["rigid"] or base_trials["rigid-impedance"]
        base_speed = _extras(locked)["speed_m_s"] if locked else None
        target, source = panel_target(dict(pkey), base_speed)
        panels.append(
            {
                "panel": name,
                "config": dict(pkey),
                "baselines": sorted(present & set(BASELINES)),
                "target_speed_m_s": target,
                "target_source": source,
                "n_seeds": len({t.config.get("seed", 0) for ts in cellmap.values() for t in ts}),
            }
        )
        for (spine, gains, k, d), ts in sorted(cellmap.items(), key=lambda kv: repr(kv[0])):
            nf = sum(t.fell for t in ts)
            rate, lo, hi = wilson(nf, len(ts))
            extras = _extras(ts)
            if gains:
                extras["other_gains"] = json.dumps(dict(gains))
            calibrated = [t.metrics["match_value"] for t in ts if t.ok and "match_value" in t.metrics]
            if calibrated:  # the cell's calibrated input (one value per cell) and whether it met the target
                extras["match_value"] = float(calibrated[0])
                extras["match_converged"] = all(t.metrics.get("match_converged") for t in ts if t.ok)
            base = _baseline_for(spine, standing)
            extras["base_speed_m_s"] = _extras(base_trials[base])["speed_m_s"] if base else None
            for m in metrics:
                seeds = _by_seed(ts, m)
                est = mean_over_seeds(list(seeds.values()), n_boot=n_boot)
                diff = (
                    paired_difference(seeds, _by_seed(base_trials[base], m), n_boot=n_boot) if base else None
                )
                cells.append(
                    Cell(
                        name,
                        spine,
                        k,
                        d,
                        m,
                        len(ts),
                        nf,
                        rate,
                        lo,
                        hi,
                        est,
                        diff,
                        extras,
                        seeds,
                        base,
                        target,
                        COMMANDED_SPEED_TOLERANCE_M_S if source in ("commanded", MATCHED)
                        else SPEED_TOLERANCE_M_S,
                    )
                )
    return {"panels": panels, "metrics": metrics, "cells": cells, "optima": optima(cells, n_boot)}


def _brief(c: Cell) -> dict:
    return {
        "k": c.k,
        "d": c.d,
        "mean": c.est.value if c.est else None,
        "speed_m_s": c.extras.get("speed_m_s"),
        "n_fell": c.n_fell,
        "n": c.n,
    }


def optima(cells: list[Cell], n_boot: int = 400) -> list[dict]:
    """Per (panel, spine, metric) over k x d: `best_of` and the cells it left out."""
    out = []
    key = defaultdict(list)
    for c in cells:
        if c.spine not in BASELINES:
            key[(c.panel, c.spine, c.metric)].append(c)
    for (panel, spine, metric), cs in key.items():
        best, near, left = best_of(cs, n_boot)
        doc = {
            "panel": panel,
            "spine": spine,
            "metric": metric,
            "best": best.row() if best else None,
            **{f"left_out_{k}": [_brief(c) for c in v] for k, v in left.items() if k != "selection"},
            "selection": left.get("selection"),
        }
        if best is not None:
            doc.update(
                near_best=[_brief(c) for c in near],
                near_best_k=sorted({c.k for c in near if c.k is not None}),
                near_best_d=sorted({c.d for c in near if c.d is not None}),
            )
        out.append(doc)
    return out


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


def write_report(folder: Path | list[Path], n_boot: int = 400, out: Path | None = None) -> list[Path]:
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
    from sparc_quad.study.claims import document, evaluate, markdown

    claims = evaluate(res)
    seeds = Counter(c.n for c in res["cells"]).most_common(1)[0][0] if res["cells"] else None
    atomic_write_text(out / "claims.json", json.dumps(jsonable(document(claims, seeds)), indent=1,
                                                      allow_nan=False) + "\n")
    atomic_write_text(out / "claims.md", markdown(claims, seeds))
    paths += [out / "claims.json", out / "claims.md"]
    from sparc_quad.study.robustness import frequency_windows
    from sparc_quad.study.robustness import markdown as windows_markdown

    windows = frequency_windows(res)
    if windows:  # panels over the gait frequency: the robustness finding beside the cost
        atomic_write_text(out / "frequency_window.json",
                          json.dumps(jsonable(windows), indent=1, allow_nan=False) + "\n")
        atomic_write_text(out / "frequency_window.md", windows_markdown(windows))
        paths += [out / "frequency_window.json", out / "frequency_window.md"]
    paths += write_plots(res, out, fn, PLOTTED)
    return paths
