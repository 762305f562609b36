"""The authors' spine claims checked against a study's analysed cells, one stated rule per claim.

Claims (github.com/YueWang996/sparc README "Simulation Results"; arXiv 2510.01984 abstract):
  C1 flat ground: the best stiffness is 800-1200 N/m;
  C2 lowest CoT at 500-800 N/m with 8-20 N*s/m at 70-80 mm stride length (their gait's `step_length` L);
  C3 21 % less power at 0.9 m/s for the best compliant spine against a rigid one;
  C4 efficiency insensitive to the spine at low speed;
  C5 downhill: higher stiffness, 1000-1500 N/m;  C6 uphill: lower stiffness, 500-1000 N/m;
and F1, this project's own finding to keep in view: compliant spines cost more positive work than a locked
one (Solo12, both gaits).

Rows per (robot, engine, gait, spine). A claim whose conditions the study does not create (no 0.9 m/s
panel, L not a parameter of the gait, no slopes, every cell fell or ran off speed) is "not tested", never
"not reproduced". Best cells come from `report.best_of` (on speed, not falling more than the safest cell);
picking the best of many cells favours it (winner's curse): read C1-C3 with that in mind.

Each claim carries its source's own words (`SOURCES`) beside this project's reading of them and the rule,
so a reader can judge the operationalisation. A cell with fewer than `MIN_SEEDS` seeds is never judged:
a rule that has nothing else to judge says "not tested (n < minimum)". `markdown` states how many
verdicts the report gives and what their uncorrected 95 % intervals control (`multiplicity`).
"""

from __future__ import annotations

import math
from collections import defaultdict

import numpy as np

from sparc_quad.metrics import ELEC_SENSITIVITY
from sparc_quad.study.best_cell import (
    BASELINE_OF,
    BASELINES,
    MIN_SEEDS,
    MIN_STANDING_SHARE,
    NOT_TESTED_N,
    SELECTION_SPLIT,
    best_of,
    enough_seeds,
    held_out,
    stands,
)
from sparc_quad.study.stats import CONFIDENCE, mean_over_seeds, paired_difference, power_statement

HEADLINE = "cot_pos_total"
ELEC = "cot_elec_total"
REF_SPEED_M_S = 0.9
REF_SPEED_TOLERANCE_M_S = 0.1
LOW_SPEED_GAP_M_S = 0.2
C1_K = (800.0, 1200.0)
C2_K, C2_D, C2_L_M = (500.0, 800.0), (8.0, 20.0), (0.070, 0.080)
C3_SAVING_PCT = -21.0
C4_RATIO = 0.5
C5_K = (1000.0, 1500.0)
C6_K = (500.0, 1000.0)
COMPLIANT = ("impedance", "passive")
MIN_JUDGED_CELLS = 2  # a best cell needs another on-speed cell to be best against
DEFAULT_HOST, DEFAULT_ENGINE = "solo12", "pybullet"

CLAIM_TEXT = {
    "C1": "flat-ground optimum k 800-1200 N/m",
    "C2": "lowest CoT at 500-800 N/m, 8-20 N·s/m, L 70-80 mm",
    "C3": "21 % less power at 0.9 m/s than rigid (CoT_pos)",
    "C3e": "21 % less power at 0.9 m/s than rigid (CoT_elec)",
    "C4": "insensitive to the spine at low speed",
    "C5": "downhill optimum k 1000-1500 N/m",
    "C6": "uphill optimum k 500-1000 N/m",
    "F1": "(project) compliant costs more positive work than locked",
}
RULES = {
    "C1": "best cell (lowest mean CoT_pos among on-speed cells not falling more than the safest) has k_x in "
    "800-1200 and so has every cell whose seed-paired difference to it reaches 0 (at least 2 cells "
    "ranked, else not tested): reproduced; neither: "
    "not reproduced; otherwise not resolved",
    "C2": "the same best-cell rule over k_x x d_x x L (panels differing only in the gait's step_length): "
    "k, d and L in range: reproduced; no near-best cell has all three: not reproduced; L fixed in "
    "70-80 mm: judged on k, d at that L; no L parameter: not tested",
    "C3": "best on-speed cell's CoT_pos against the on-speed baseline nearest the target (impedance: "
    "rigid-impedance first, passive: locked first; over the step-length family for gait A), paired by "
    "seed, target 0.9 +- 0.1 m/s; no on-speed baseline: not tested; CI below 0 reaching -21 %: "
    "reproduced; CI above -21 %: not reproduced; CI containing 0 and -21 %: not resolved",
    "C3e": "C3's rule on CoT_elec; the finding shows the same cell with the winding loss constants x 0.5 "
    "and x 2",
    "C4": "range over the common on-speed k x d cells of % against the baseline, low-speed panel over the "
    "0.9 m/s one, 95 % CI by resampling seeds: CI below 0.5: reproduced; above: not reproduced; else "
    "not resolved",
    "C5": "C1's rule with 1000-1500 N/m on the downhill panels (slope < 0)",
    "C6": "C1's rule with 500-1000 N/m on the uphill panels (slope > 0)",
    "F1": "share of on-speed cells whose CoT_pos against the on-speed locked spine of the same panel has "
    "a CI above 0: all: reproduced; any below 0: not reproduced; else partly",
}

README = (
    'authors\' README, "Simulation Results", github.com/YueWang996/sparc README.md at commit 1c8013a, '
    "bold markup dropped"
)
ABSTRACT = "arXiv 2510.01984 v3 abstract"
# claim -> (source, the source's own words, exact; how this project reads them where the rule narrows them)
SOURCES = {
    "C1": (README, "Flat terrain: Moderate stiffness (800-1200 N/m) balances efficiency and stability",
           "the README weighs efficiency and stability; the rule ranks cost (CoT_pos) only, with stability "
           "a gate (a cell must stand and not fall more than the safest), not a score"),
    "C2": (README, "Optimal stride lengths (70-80 mm): Lowest cost of transport with 500-800 N/m stiffness "
           "and 8-20 N·s/m damping",
           "stride length as the gait's step_length L (gait A); cost of transport as CoT_pos over the "
           "judged window"),
    "C3": (ABSTRACT, "an optimally compliant spine reduces power consumption by 21% at 0.9 m/s compared to a "
           "rigid-spine baseline",
           "power as positive mechanical work per distance (CoT_pos; at matched speed the two are "
           "proportional); 'optimally compliant' as the best cell; 'rigid-spine baseline' as rigid-impedance "
           "for the motor-rendered spine and the locked joint for the passive one; '21%' read both as about "
           "21 % and as at least 21 %, the finding says which holds"),
    "C3e": (ABSTRACT, "an optimally compliant spine reduces power consumption by 21% at 0.9 m/s compared to "
            "a rigid-spine baseline",
            "power as electrical power per distance (CoT_elec: positive work plus winding losses from "
            "actuator constants, so the finding shows it with the constants x 0.5 and x 2)"),
    "C4": (ABSTRACT, "low-speed efficiency is insensitive to spinal properties",
           "'insensitive' as: the spread over k x d of % against the baseline at low speed is less than "
           "half of that at 0.9 m/s (the 0.5 is this project's choice)"),
    "C5": (README, "Downhill slopes: Higher stiffness (1000-1500 N/m) reduces excessive pitch-down",
           "the README judges pitch-down; the rule judges cost (CoT_pos), so a verdict speaks of cost only"),
    "C6": (README, "Uphill slopes: Lower stiffness (500-1000 N/m) enables elastic energy storage",
           "the README speaks of energy storage; the rule judges cost (CoT_pos), so a verdict speaks of cost "
           "only"),
    "F1": ("this project's own finding (Solo12, both gaits), no source's claim", None,
           "kept in view because it runs against the direction of C3"),
}


def _in(x, lo_hi) -> bool:
    return x is not None and lo_hi[0] - 1e-9 <= x <= lo_hi[1] + 1e-9


def _ci(mean, lo, hi, nd=1, unit="") -> str:
    if mean is None:
        return "–"
    if lo is None or hi is None:
        return f"{mean:.{nd}f}{unit}"
    return f"{mean:.{nd}f}{unit} [{lo:.{nd}f}, {hi:.{nd}f}]"


def _g(x) -> str:
    return "–" if x is None else f"{x:g}"


def _robot(cfg: dict) -> tuple:
    """(host, engine, gait); a matched-speed study's gait is named apart: its cells are compared at one
    achieved speed, a commanded study's at one command."""
    gait = cfg.get("gait")
    if "match_speed" in cfg:
        gait = f"{gait} (speed matched by {cfg.get('match_by', 'speed')})"
    return (cfg.get("host", DEFAULT_HOST), cfg.get("engine", DEFAULT_ENGINE), gait)


def _family(cfg: dict, drop: tuple[str, ...]) -> tuple:
    return tuple(sorted((k, v) for k, v in cfg.items() if k not in drop))


def _flat(p: dict) -> bool:
    return abs(float(p["config"].get("slope", 0.0))) < 1e-9 and not p["config"].get("latency_steps")


def _cells(analysis: dict, panel: str, spine: str, metric: str = HEADLINE) -> list:
    return [c for c in analysis["cells"] if c.panel == panel and c.spine == spine and c.metric == metric]


def _ref_panel(panels: list[dict]) -> dict | None:
    """The flat panel nearest 0.9 m/s, preferring the authors' L when the gait has one."""
    ps = [p for p in panels if p.get("target_speed_m_s") is not None]
    if not ps:
        return None

    def score(p):
        L = p["config"].get("step_length")
        return (0 if L is None or _in(L, C2_L_M) else 1, abs(p["target_speed_m_s"] - REF_SPEED_M_S))

    return min(ps, key=score)


def _judged(cs: list, left: dict) -> int:
    """How many cells the best-cell rule ranked (on speed, enough seeds, not falling more than the safest)."""
    return (sum(c.est is not None for c in cs) - len(left["off_speed"]) - len(left.get("fall_more", []))
            - len(left.get("falls", [])) - len(left.get("few_seeds", [])))


def _untested(left: dict) -> str:
    """The verdict of a rule with too few judged cells: says so when cells were left out for their n."""
    return NOT_TESTED_N if left.get("few_seeds") else "not tested"


def _span(ns) -> str:
    """A set of counts as '10' or '8-10'."""
    ns = sorted(set(ns))
    if not ns:
        return "0"
    return f"{ns[0]}" if len(ns) == 1 else f"{ns[0]}-{ns[-1]}"


def _n(ests) -> str:
    """The seed counts behind a set of intervals: 'n = 10' or 'n = 8-10'."""
    return f"n = {_span(e.n_seeds for e in ests if e is not None)}"


def _why_untested(cs: list, left: dict) -> str:
    n, nf = sum(c.n for c in cs), sum(c.n_fell for c in cs)
    off = left.get("off_speed", [])
    speeds = sorted(c.extras.get("speed_m_s") or 0.0 for c in off)
    txt = f"{speeds[0]:.2f}-{speeds[-1]:.2f} m/s" if speeds else ""
    few = left.get("few_seeds", [])
    few_txt = f"{len(few)} cells with n < minimum ({_span(c.n for c in few)} seeds, need {MIN_SEEDS}), "
    few_txt = few_txt if few else ""
    return (
        f"{_judged(cs, left)} of {len(cs)} cells on speed and standing (need {MIN_JUDGED_CELLS}): {nf}/{n} "
        f"trials fell, {few_txt}{len(left.get('falls', []))} cells not tested (falls: fewer than "
        f"{MIN_STANDING_SHARE:.0%} of their seeds, or fewer than {MIN_SEEDS}, standing), {len(off)} cells "
        f"off speed {txt}"
    ).rstrip()


def _estimate(best, left: dict):
    """The best cell's interval on the seeds it was not chosen on, when the choice was split."""
    if left.get("selection") == SELECTION_SPLIT:
        return mean_over_seeds(list(held_out(best.seeds).values())) or best.est
    return best.est


def _best_k_rule(analysis, panel, spine, k_range, claim, base) -> dict:
    cs = _cells(analysis, panel["panel"], spine)
    best, near, left = best_of(cs)
    if best is None or _judged(cs, left) < MIN_JUDGED_CELLS:
        return {**base, "claim": claim, "verdict": _untested(left), "finding": _why_untested(cs, left)}
    ks = sorted({c.k for c in near})
    if _in(best.k, k_range):
        v = "reproduced" if all(_in(k, k_range) for k in ks) else "not resolved"
    else:
        v = "not resolved" if any(_in(k, k_range) for k in ks) else "not reproduced"
    e = _estimate(best, left)
    return {
        **base,
        "claim": claim,
        "verdict": v,
        "best_k": best.k,
        "best_d": best.d,
        "near_best_k": ks,
        "finding": f"{panel['panel']}: best k_x {_g(best.k)} N/m (d_x {_g(best.d)}), CoT_pos "
        f"{_ci(e.value, e.lo, e.hi, 2)} at {best.extras.get('speed_m_s') or 0:.2f} m/s, "
        f"n = {e.n_seeds} seeds; not distinguishable: k_x {', '.join(_g(k) for k in ks)}; "
        f"left out: {len(left['off_speed'])} off-speed, {len(left['few_seeds'])} n < minimum, "
        f"{len(left['falls'])} not tested (falls), "
        f"{len(left['fall_more'])} falling more, {len(left['all_fell'])} all fell; best {left['selection']}",
    }


def _c2(analysis, ref, family_panels, spine, base) -> dict:
    L_ref = ref["config"].get("step_length")
    if ref["config"].get("match_by") == "step_length":
        return {**base, "claim": "C2", "verdict": "not tested",
                "finding": "L is calibrated per cell to match the speed, not a factor"}
    if L_ref is None:
        return {
            **base,
            "claim": "C2",
            "verdict": "not tested",
            "finding": "stride length is not a parameter of this gait (emergent: speed / frequency)",
        }
    Ls = sorted({p["config"]["step_length"] for p in family_panels})
    cs = [c for p in family_panels for c in _cells(analysis, p["panel"], spine)]
    L_of = {p["panel"]: p["config"]["step_length"] for p in family_panels}
    best, near, left = best_of(cs)
    if best is None or _judged(cs, left) < MIN_JUDGED_CELLS:
        return {**base, "claim": "C2", "verdict": _untested(left), "finding": _why_untested(cs, left)}
    varied = any(_in(L, C2_L_M) for L in Ls) and any(not _in(L, C2_L_M) for L in Ls)

    def hit(c) -> bool:
        return _in(c.k, C2_K) and _in(c.d, C2_D) and (not varied or _in(L_of[c.panel], C2_L_M))

    if not varied and not _in(L_ref, C2_L_M):
        return {
            **base,
            "claim": "C2",
            "verdict": "not tested",
            "finding": f"L fixed at {1000 * L_ref:.0f} mm, outside the claimed 70-80 mm",
        }
    v = (
        "reproduced"
        if hit(best) and all(hit(c) for c in near)
        else ("not reproduced" if not any(hit(c) for c in near) else "not resolved")
    )
    e = _estimate(best, left)
    scope = (
        f"over L {', '.join(f'{1000 * L:.0f}' for L in Ls)} mm"
        if varied
        else f"k, d only, at the authors' L = {1000 * L_ref:.0f} mm"
    )
    return {
        **base,
        "claim": "C2",
        "verdict": v,
        "best_k": best.k,
        "best_d": best.d,
        "best_L_m": L_of[best.panel],
        "finding": f"{scope}: best (k_x, d_x, L) = ({_g(best.k)}, {_g(best.d)}, "
        f"{1000 * L_of[best.panel]:.0f} mm), CoT_pos {_ci(e.value, e.lo, e.hi, 2)}, n = {e.n_seeds} seeds "
        f"(best {left['selection']}); "
        f"{sum(hit(c) for c in near)}/{len(near)} near-best cells in the claimed ranges",
    }


def _saving_verdict(lo, hi) -> str:
    if lo is None or hi is None:
        return "not tested"
    if hi < 0 and lo <= C3_SAVING_PCT:
        return "reproduced"
    if lo > C3_SAVING_PCT:
        return "not reproduced" + (" (costs more)" if lo > 0 else "")
    return "not resolved"


def _c3(analysis, ref, family_panels, spine, base, metric: str, claim: str) -> dict:
    """Best on-speed compliant cell against the on-speed baseline nearest the target, over the panels of
    `family_panels` (one panel, or the step-length family of gait A), paired by seed."""
    if abs(ref["target_speed_m_s"] - REF_SPEED_M_S) > REF_SPEED_TOLERANCE_M_S:
        return {
            **base,
            "claim": claim,
            "verdict": "not tested",
            "finding": f"no 0.9 m/s panel (nearest target {ref['target_speed_m_s']:.2f} m/s)",
        }
    names = {p["panel"] for p in family_panels}
    cs = [c for n in names for c in _cells(analysis, n, spine, metric)]
    if metric == ELEC and cs and all(c.est is None for c in cs) and any(c.n > c.n_fell for c in cs):
        return {**base, "claim": claim, "verdict": "not tested",
                "finding": "CoT_elec is not defined for this robot: its leg actuators' winding losses are "
                "not known (metrics: the host's winding constants), so no trial has a value"}
    best, _, left = best_of(cs)
    if best is None:
        return {**base, "claim": claim, "verdict": _untested(left), "finding": _why_untested(cs, left)}
    bases = [
        c
        for c in analysis["cells"]
        if c.panel in names
        and c.metric == metric
        and c.est is not None
        and c.spine in (BASELINE_OF[spine], *BASELINES)
    ]
    on = [c for c in bases if not c.off_speed and stands(c)]
    pick = [c for c in on if c.spine == BASELINE_OF[spine]] or on
    few = [c for c in bases if not enough_seeds(c)]
    if not pick and few:
        return {
            **base,
            "claim": claim,
            "verdict": NOT_TESTED_N,
            "finding": "baseline "
            + ", ".join(f"{c.spine} {c.n} seeds" for c in few)
            + f" (need {MIN_SEEDS})",
        }
    if not pick:
        speeds = ", ".join(f"{c.spine} {c.extras.get('speed_m_s') or 0:.2f}" for c in bases) or "none ran"
        return {
            **base,
            "claim": claim,
            "verdict": "not tested",
            "finding": f"no standing baseline within {bases[0].speed_tolerance_m_s if bases else 0.05:.2f} "
            f"m/s of {ref['target_speed_m_s']:.2f} m/s ({speeds} m/s): "
            f"no matched-speed comparison; unmatched, {_dominance(cs)}",
        }
    t = ref["target_speed_m_s"]
    b = min(pick, key=lambda c: abs((c.extras.get("speed_m_s") or 0) - t))
    split = left["selection"] == SELECTION_SPLIT
    d = paired_difference(held_out(best.seeds), held_out(b.seeds)) if split else paired_difference(
        best.seeds, b.seeds)
    if d is None:
        return {
            **base,
            "claim": claim,
            "verdict": "not tested",
            "finding": "no seed in common with the baseline",
        }

    def where(c) -> str:
        return f"{c.panel} ({_g(c.k)}, {_g(c.d)}) at {c.extras.get('speed_m_s') or 0:.2f} m/s"

    text = f"{where(best)} against {b.spine} {where(b)}: {_ci(d.value, d.lo, d.hi, 0, ' %')}, "
    text += f"n = {d.n_seeds} seeds (best {left['selection']})"
    if d.lo is not None and d.hi is not None:  # the source's "21 %" read two ways
        about = d.lo <= C3_SAVING_PCT <= d.hi and d.hi < 0
        text += (f"; about 21 % (CI holds -21 % and excludes 0): {'yes' if about else 'no'}; at least 21 % "
                 f"(CI at or below -21 %): {'yes' if d.hi <= C3_SAVING_PCT else 'no'}")
    if metric == ELEC:
        sens = []
        for c, scale in ELEC_SENSITIVITY.items():
            mb = next(
                (
                    x
                    for x in analysis["cells"]
                    if x.metric == f"cot_{c}_total"
                    and x.panel == best.panel
                    and (x.spine, x.k, x.d) == (best.spine, best.k, best.d)
                ),
                None,
            )
            mr = next(
                (
                    x
                    for x in analysis["cells"]
                    if x.metric == f"cot_{c}_total" and x.panel == b.panel and x.spine == b.spine
                ),
                None,
            )
            o = paired_difference(mb.seeds, mr.seeds) if mb is not None and mr is not None else None
            if o is not None:
                sens.append(f"c x {scale:g}: {_ci(o.value, o.lo, o.hi, 0, ' %')}, n = {o.n_seeds} seeds")
        text += "; winding constants " + ("; ".join(sens) if sens else "–")
    return {
        **base,
        "claim": claim,
        "verdict": _saving_verdict(d.lo, d.hi),
        "best_k": best.k,
        "best_d": best.d,
        "baseline": b.spine,
        "diff_pct": d.value,
        "diff_lo": d.lo,
        "diff_hi": d.hi,
        "finding": text,
    }


def _dominance(cs: list) -> str:
    """How cells compare with their own panel's baseline when speeds differ: faster and cheaper (CI)."""
    rated = [c for c in cs if c.est is not None and c.diff_pct is not None]
    both = sum(
        1
        for c in rated
        if c.diff_pct.hi is not None
        and c.diff_pct.hi < 0
        and (c.extras.get("speed_m_s") or 0) > (c.extras.get("base_speed_m_s") or math.inf)
    )
    dearer = sum(1 for c in rated if c.diff_pct.lo is not None and c.diff_pct.lo > 0)
    return (
        f"{both}/{len(rated)} cells ran faster than their panel's baseline and cost less (CI below 0), "
        f"{dearer} cost more ({_n(c.diff_pct for c in rated)} seeds)"
    )


def _range_ratio(low_cells, ref_cells, low_base, ref_base, n_boot=2000, seed=0):
    """Range of % vs baseline at low speed / at 0.9 m/s over common cells; percentile CI over seeds."""

    def seed_means(c):
        return {s: float(np.mean(v)) for s, v in c.seeds.items()}

    def diffs(cells, base, pick):
        b = seed_means(base)
        out = []
        for c in cells:
            m = seed_means(c)
            ss = [s for s in pick if s in m and s in b]
            if not ss:
                return None
            out.append(100.0 * (np.mean([m[s] for s in ss]) / np.mean([b[s] for s in ss]) - 1.0))
        return out

    seeds = sorted(set.intersection(*(set(c.seeds) for c in [*low_cells, *ref_cells, low_base, ref_base])))
    if len(seeds) < 2:
        return None

    def ratio(pick):
        lo, rf = diffs(low_cells, low_base, pick), diffs(ref_cells, ref_base, pick)
        if lo is None or rf is None or np.ptp(rf) == 0:
            return math.nan
        return float(np.ptp(lo) / np.ptp(rf))

    value = ratio(seeds)
    rng = np.random.default_rng(seed)
    reps = np.array([ratio(list(rng.choice(seeds, len(seeds)))) for _ in range(n_boot)])
    reps = reps[np.isfinite(reps)]
    a = (1 - CONFIDENCE) / 2
    lo, hi = np.quantile(reps, [a, 1 - a]) if reps.size else (math.nan, math.nan)
    return value, float(lo), float(hi), len(seeds)


def _c4(analysis, ref, low, spine, base) -> dict:
    if low is None:
        return {**base, "claim": "C4", "verdict": "not tested", "finding": "no low-speed panel"}

    def usable(p):
        return {
            (c.k, c.d): c
            for c in _cells(analysis, p["panel"], spine)
            if c.est is not None and not c.off_speed and c.diff_pct is not None and stands(c)
        }

    compared = [c for p in (low, ref) for c in _cells(analysis, p["panel"], spine) if c.est is not None]

    a, b = usable(low), usable(ref)
    common = sorted(set(a) & set(b), key=repr)

    def base_cell(p):
        name = next((c.baseline for c in _cells(analysis, p["panel"], spine) if c.baseline), None)
        return next((c for c in _cells(analysis, p["panel"], name)), None) if name else None

    lb, rb = base_cell(low), base_cell(ref)
    few = [c for c in [*compared, lb, rb] if c is not None and not enough_seeds(c)]
    if len(common) < 2 or lb is None or rb is None or lb.est is None or rb.est is None or not (
            stands(lb) and stands(rb)) or lb.off_speed or rb.off_speed:
        return {
            **base,
            "claim": "C4",
            "verdict": NOT_TESTED_N if few else "not tested",
            "finding": f"{len(common)} common on-speed cells at {low['target_speed_m_s']:.2f} and "
            f"{ref['target_speed_m_s']:.2f} m/s (need 2, and both baselines standing and on speed)"
            + (f"; {len(few)} cells with n < minimum (need {MIN_SEEDS} seeds)" if few else ""),
        }
    r = _range_ratio([a[k] for k in common], [b[k] for k in common], lb, rb)
    if r is None or r[3] < MIN_SEEDS:
        got = r[3] if r else "fewer than 2"
        return {**base, "claim": "C4", "verdict": NOT_TESTED_N,
                "finding": f"{got} seeds stand in every compared cell (need {MIN_SEEDS})"}
    value, lo, hi, n = r
    v = "reproduced" if hi < C4_RATIO else ("not reproduced" if lo >= C4_RATIO else "not resolved")
    return {
        **base,
        "claim": "C4",
        "verdict": v,
        "ratio": value,
        "ratio_lo": lo,
        "ratio_hi": hi,
        "finding": f"range of % vs baseline over {len(common)} cells, {low['target_speed_m_s']:.2f} over "
        f"{ref['target_speed_m_s']:.2f} m/s: {_ci(value, lo, hi, 2)} (n = {n} seeds)",
    }


def _f1(analysis, ref, spine, base) -> dict:
    rated = [c for c in _cells(analysis, ref["panel"], spine) if c.est is not None]
    cs = [c for c in rated if not c.off_speed and stands(c)]
    locked = next(
        (
            c
            for c in analysis["cells"]
            if c.panel == ref["panel"] and c.spine == "rigid" and c.metric == HEADLINE
        ),
        None,
    )
    few = [c for c in [*rated, locked] if c is not None and not enough_seeds(c)]
    if few and (not cs or (locked is not None and not enough_seeds(locked))):
        return {
            **base,
            "claim": "F1",
            "verdict": NOT_TESTED_N,
            "finding": f"{len(few)} cells (locked spine included: {'yes' if locked in few else 'no'}) ran "
            f"{_span(c.n for c in few)} seeds (need {MIN_SEEDS})",
        }
    if locked is not None and locked.est is not None and not stands(locked):
        return {
            **base,
            "claim": "F1",
            "verdict": "not tested",
            "finding": f"the locked spine fell in {locked.n_fell}/{locked.n} seeds: not judged (falls)",
        }
    if locked is not None and locked.est is not None and locked.off_speed:
        return {
            **base,
            "claim": "F1",
            "verdict": "not tested",
            "finding": f"the locked spine ran {locked.extras.get('speed_m_s') or 0:.2f} m/s, off the "
            f"{ref['target_speed_m_s']:.2f} m/s target: no matched-speed comparison",
        }
    if not cs or locked is None or locked.est is None:
        return {
            **base,
            "claim": "F1",
            "verdict": "not tested",
            "finding": "no on-speed standing cells or no locked spine",
        }
    ds = [paired_difference(c.seeds, locked.seeds) for c in cs]
    ds = [d for d in ds if d is not None]
    if not ds:
        return {**base, "claim": "F1", "verdict": "not tested",
                "finding": "no seed in common with the locked spine"}
    more = sum(d.lo is not None and d.lo > 0 for d in ds)
    less = sum(d.hi is not None and d.hi < 0 for d in ds)
    v = "reproduced" if more == len(ds) else ("not reproduced" if less else "partly")
    vals = sorted(d.value for d in ds)
    return {
        **base,
        "claim": "F1",
        "verdict": v,
        "finding": f"{ref['panel']}: {more}/{len(ds)} cells cost more than locked (CI > 0), {less} less; "
        f"% vs locked {vals[0]:+.0f} to {vals[-1]:+.0f} ({_n(ds)} seeds each)",
    }


def evaluate(analysis: dict) -> list[dict]:
    """Rows: claim, robot, engine, gait, spine, finding (with intervals), verdict, rule, numbers."""
    by_robot: dict[tuple, list[dict]] = defaultdict(list)
    for p in analysis["panels"]:
        by_robot[_robot(p["config"])].append(p)
    out: list[dict] = []
    for (host, engine, gait), panels in sorted(by_robot.items(), key=repr):
        flat = [p for p in panels if _flat(p)]
        ref = _ref_panel(flat)
        for spine in COMPLIANT:
            base = {"robot": host, "engine": engine, "gait": gait, "spine": spine}
            if ref is None:
                out += [
                    {
                        **base,
                        "claim": c,
                        "verdict": "not tested",
                        "finding": "no flat panel with a target speed",
                    }
                    for c in ("C1", "C2", "C3", "C3e", "C4", "F1")
                ]
            else:
                fam = _family(ref["config"], ("step_length",))
                family = [p for p in flat if _family(p["config"], ("step_length",)) == fam]
                speed_fam = _family(ref["config"], ("speed", "match_speed", "step_length", "frequency"))
                lows = [
                    p
                    for p in flat
                    if _family(p["config"], ("speed", "match_speed", "step_length", "frequency")) == speed_fam
                    and p.get("target_speed_m_s") is not None
                    and p["target_speed_m_s"] < ref["target_speed_m_s"] - LOW_SPEED_GAP_M_S
                ]
                low = min(lows, key=lambda p: p["target_speed_m_s"]) if lows else None
                out.append(_best_k_rule(analysis, ref, spine, C1_K, "C1", base))
                out.append(_c2(analysis, ref, family, spine, base))
                out.append(_c3(analysis, ref, family, spine, base, HEADLINE, "C3"))
                out.append(_c3(analysis, ref, family, spine, base, ELEC, "C3e"))
                out.append(_c4(analysis, ref, low, spine, base))
                out.append(_f1(analysis, ref, spine, base))
            for claim, sign, k_range in (("C5", -1, C5_K), ("C6", 1, C6_K)):
                sl = [
                    p
                    for p in panels
                    if sign * float(p["config"].get("slope", 0.0)) > 1e-9
                    and not p["config"].get("latency_steps")
                ]
                r = _ref_panel(sl)
                out.append(
                    _best_k_rule(analysis, r, spine, k_range, claim, base)
                    if r
                    else {**base, "claim": claim, "verdict": "not tested", "finding": "no such slope"}
                )
    for r in out:
        src, words, reading = SOURCES[r["claim"]]
        r.update(source=src, source_words=words, reading=reading, rule=RULES[r["claim"]])
    return out


def multiplicity(rows: list[dict], seeds_per_cell: int | None = None) -> dict:
    """How many verdicts the rows give and what their intervals control: each verdict uses 95 % intervals
    computed for it alone, with no family-wise correction (the claims are separate questions, each read on
    its own; a Bonferroni bound over every row would make the intervals at 10 seeds about twice as wide and
    leave nearly every claim unresolved), so the expected number of false verdicts grows with their count."""
    n = sum(not r["verdict"].startswith("not tested") for r in rows)
    alpha = 1.0 - CONFIDENCE
    return {
        "rows": len(rows),
        "verdicts": n,
        "not_tested": len(rows) - n,
        "confidence_per_interval": CONFIDENCE,
        "familywise_correction": "none",
        "expected_false_verdicts": alpha * n,
        "chance_of_any_false_verdict": 1.0 - CONFIDENCE**n,
        "min_seeds_per_cell": MIN_SEEDS,
        "seeds_per_cell": seeds_per_cell,
        "fall_power": None if not seeds_per_cell else power_statement(seeds_per_cell),
    }


def multiplicity_text(m: dict) -> str:
    """The report's statement of how many verdicts it gives and what that means."""
    head = (
        f"This report gives {m['verdicts']} verdicts (reproduced, not reproduced, not resolved or partly) in "
        f"{m['rows']} rows; the other {m['not_tested']} rows are not tested. A cell is judged only with at "
        f"least {m['min_seeds_per_cell']} seeds run and standing, else \"{NOT_TESTED_N}\" or \"not tested "
        "(falls)\". Every interval is a 95 % interval for its own verdict, shown with its n (seeds), with no "
        "family-wise correction (no Bonferroni or Holm across rows, nor across the cells one rule compares)"
    )
    power = f" {m['fall_power']}" if m.get("fall_power") else ""
    if not m["verdicts"]:
        return head + ": there is no verdict to correct." + power
    return (
        head + f": if every interval covers at its nominal 95 %, about {m['expected_false_verdicts']:.1f} of "
        f"the {m['verdicts']} verdicts can be wrong by chance alone, and the chance that at least one is "
        f"wrong is up to {m['chance_of_any_false_verdict']:.0%}. A rule that compares several cells (C1, C2, "
        "C5, C6 over the near-best set, F1 over a panel's cells) makes one such comparison per cell, so its "
        "verdict can err more often than 5 %. Read a single verdict with that in mind; an agreement across "
        "engines, hosts and gaits counts for more than any one row." + power
    )


def document(rows: list[dict], seeds_per_cell: int | None = None) -> dict:
    """claims.json: the multiplicity statement, each claim's source words and rule, and the rows."""
    claims = {
        c: {"text": CLAIM_TEXT[c], "source": SOURCES[c][0], "source_words": SOURCES[c][1],
            "reading": SOURCES[c][2], "rule": RULES[c]}
        for c in CLAIM_TEXT
    }
    return {"multiplicity": multiplicity(rows, seeds_per_cell), "claims": claims, "rows": rows}


def markdown(rows: list[dict], seeds_per_cell: int | None = None) -> str:
    """claims.md: the multiplicity statement (with what `seeds_per_cell` seeds can tell of fall rates), the
    verdict table, then per claim its source's words beside this project's reading and rule."""
    lines = [
        multiplicity_text(multiplicity(rows, seeds_per_cell)),
        "",
        "| claim (authors) | robot | engine | gait | spine | this study (95 % CI, n seeds) | verdict |",
        "|---|---|---|---|---|---|---|",
    ]
    order = list(CLAIM_TEXT)
    for r in sorted(
        rows, key=lambda r: (order.index(r["claim"]), r["robot"], r["engine"], r["gait"] or "", r["spine"])
    ):
        lines.append(
            f"| {r['claim']}: {CLAIM_TEXT[r['claim']]} | {r['robot']} | {r['engine']} | {r['gait']} | "
            f"{r['spine']} | {r['finding']} | {r['verdict']} |"
        )
    lines += ["", "Claims as their sources state them, this project's reading, and the rules:"]
    for c, rule in RULES.items():
        src, words, reading = SOURCES[c]
        said = f'"{words}" ({src})' if words else src
        lines.append(f"- {c}: {said}. Read here as: {reading}. Rule: {rule}")
    return "\n".join(lines) + "\n"
