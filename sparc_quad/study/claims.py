"""The authors' four spine claims checked against a study's analysed cells, with a stated rule per claim.

Claims (SPARC repository README; arXiv 2510.01984 abstract):
  C1 flat ground: the best stiffness is 800-1200 N/m;
  C2 lowest CoT at 500-800 N/m with 8-20 N*s/m and 70-80 mm strides;
  C3 21 % less power at 0.9 m/s for the best compliant spine against a rigid one;
  C4 efficiency insensitive to the spine at low speed.
Each is judged per gait family and spine variant (motor-rendered impedance, passive spring-damper) on the
study's flat-ground cells; "not tested" when the study has no cells for it. Picking the best of many cells
favours it (winner's curse): C1-C3 use the best cell's CI as it is, so read them with that in mind.
"""

from __future__ import annotations

from sparc_quad.metrics import COTS
from sparc_quad.study.stats import wilson

HEADLINE = "cot_pos_total"
REF_SPEED_M_S = 0.9
C1_K = (800.0, 1200.0)
C2_K, C2_D, C2_STRIDE_M = (500.0, 800.0), (8.0, 20.0), (0.070, 0.080)
C3_SAVING_PCT = -21.0
POWER_METRICS = tuple((f"cot_{c}_total", f"CoT_{c}") for c in COTS)  # C3 on each energy definition
COMPLIANT = ("impedance", "passive")
BASELINES = ("rigid", "rigid-impedance")


def _in(x, lo_hi) -> bool:
    return x is not None and lo_hi[0] <= x <= lo_hi[1]


def _ci(mean, lo, hi, nd=1, unit="") -> str:
    if mean is None:
        return "–"
    if lo is None or hi is None:
        return f"{mean:.{nd}f}{unit}"
    return f"{mean:.{nd}f}{unit} [{lo:.{nd}f}, {hi:.{nd}f}]"


def _g(x) -> str:
    return "–" if x is None else f"{x:g}"


def _falls(row: dict) -> str:
    return f"; fell {row['n_fell']}/{row['n']}, CoT over the rest" if row.get("n_fell") else ""


def _speed_txt(row: dict) -> str:
    v = row.get("speed_m_s")
    return "–" if v is None else f"{v:.2f} m/s"


def _flat_panels(panels: list[dict]) -> list[dict]:
    return [p for p in panels if abs(float(p["config"].get("slope", 0.0))) < 1e-9]


def _speed(p: dict) -> float | None:
    v = p["config"].get("speed")
    return float(v) if isinstance(v, int | float) else None


def _pick_speed(panels: list[dict], gait: str, target: float) -> dict | None:
    ps = [p for p in panels if p["config"].get("gait") == gait and _speed(p) is not None]
    return min(ps, key=lambda p: abs(_speed(p) - target)) if ps else None


def _optimum(optima: list[dict], panel: str, spine: str, metric: str) -> dict | None:
    return next(
        (o for o in optima if o["panel"] == panel and o["spine"] == spine and o["metric"] == metric), None
    )


def evaluate(analysis: dict) -> list[dict]:
    """Rows: claim, gait, spine, finding (text with CIs), verdict, numbers."""
    panels = _flat_panels(analysis["panels"])
    rows_by_cell = [c.row() for c in analysis["cells"]]
    optima = analysis["optima"]
    gaits = sorted({p["config"].get("gait") for p in panels})
    out: list[dict] = []
    for gait in gaits:
        ref = _pick_speed(panels, gait, REF_SPEED_M_S)
        low_speeds = sorted(
            {
                _speed(p)
                for p in panels
                if p["config"].get("gait") == gait
                and _speed(p) is not None
                and _speed(p) < REF_SPEED_M_S - 1e-9
            }
        )
        low = _pick_speed(panels, gait, low_speeds[0]) if low_speeds else None
        for spine in COMPLIANT:
            base = {"gait": gait, "spine": spine}
            o = _optimum(optima, ref["panel"], spine, HEADLINE) if ref else None
            if o is None or o.get("best") is None:
                why = "no cells"
                if o is not None:
                    cs = [
                        r
                        for r in rows_by_cell
                        if r["panel"] == ref["panel"] and r["spine"] == spine and r["metric"] == HEADLINE
                    ]
                    n, nf = sum(r["n"] for r in cs), sum(r["n_fell"] for r in cs)
                    rate, lo, hi = wilson(nf, n)
                    bcs = [
                        r
                        for r in rows_by_cell
                        if r["panel"] == ref["panel"] and r["spine"] in BASELINES and r["metric"] == HEADLINE
                    ]
                    bn, bf = sum(r["n"] for r in bcs), sum(r["n_fell"] for r in bcs)
                    why = (
                        f"every trial fell: {nf}/{n} over k x d (fall rate {100 * rate:.0f} % "
                        f"[{100 * lo:.0f}, {100 * hi:.0f}]); rigid fell {bf}/{bn}; no cost to compare"
                    )
                for c in ("C1", "C2", "C3", "C4"):
                    out.append({**base, "claim": c, "finding": why, "verdict": "not tested"})
                continue
            best = o["best"]
            near = o["near_best_k"]
            # C1: where the flat-ground optimum in k lies
            if _in(best["k"], C1_K):
                v = (
                    "reproduced"
                    if all(_in(k, C1_K) for k in near)
                    else "not resolved (best in range, CI reaches k outside)"
                )
            else:
                v = (
                    "not reproduced"
                    if not any(_in(k, C1_K) for k in near)
                    else "not resolved (best outside, CI reaches the range)"
                )
            out.append(
                {
                    **base,
                    "claim": "C1",
                    "speed": _speed(ref),
                    "best_k": best["k"],
                    "best_d": best["d"],
                    "near_best_k": near,
                    "verdict": v,
                    "finding": f"{_g(_speed(ref))} m/s: best k_x {_g(best['k'])} N/m "
                    f"(d_x {_g(best['d'])}{_falls(best)}), "
                    f"CoT_pos {_ci(best['mean'], best['lo'], best['hi'], 2)} at {_speed_txt(best)}; "
                    f"k_x not distinguishable from it: {', '.join(_g(k) for k in near)}",
                }
            )
            # C2: the CoT optimum's k, d and stride length
            stride = best.get("stride_length_m")
            hit = [_in(best["k"], C2_K), _in(best["d"], C2_D), _in(stride, C2_STRIDE_M)]
            v = "reproduced" if all(hit) else ("partly reproduced" if any(hit) else "not reproduced")
            out.append(
                {
                    **base,
                    "claim": "C2",
                    "speed": _speed(ref),
                    "best_k": best["k"],
                    "best_d": best["d"],
                    "stride_m": stride,
                    "verdict": v,
                    "finding": f"best (k_x, d_x) = ({_g(best['k'])}, {_g(best['d'])}); stride "
                    f"{'–' if stride is None else f'{1000 * stride:.0f} mm'}; "
                    f"k in 500-800: {'yes' if hit[0] else 'no'}, d in 8-20: {'yes' if hit[1] else 'no'}, "
                    f"stride in 70-80 mm: {'yes' if hit[2] else 'no'}",
                }
            )
            # C3: the best compliant cell against rigid at 0.9 m/s, for every energy definition reported
            parts, verdicts, nums = [], [], {}
            for metric, label in POWER_METRICS:
                om = _optimum(optima, ref["panel"], spine, metric)
                if om is None or om.get("best") is None or om["best"].get("diff_pct") is None:
                    continue
                b = om["best"]
                d, lo, hi = b["diff_pct"], b["diff_lo"], b["diff_hi"]
                nums[metric] = {"k": b["k"], "d": b["d"], "diff_pct": d, "lo": lo, "hi": hi}
                parts.append(
                    f"{label} {_ci(d, lo, hi, 0, ' %')} at ({_g(b['k'])}, {_g(b['d'])}; {_speed_txt(b)})"
                )
                if lo is None or hi is None:
                    verdicts.append("no CI")
                elif hi < 0 and lo <= C3_SAVING_PCT:
                    verdicts.append("saving >= 21 % within CI")
                elif hi < 0:
                    verdicts.append("smaller saving")
                elif lo > 0:
                    verdicts.append("costs more")
                else:
                    verdicts.append("no significant difference")
            head = verdicts[0] if verdicts else None
            v = (
                "not tested"
                if head is None
                else "reproduced"
                if head == "saving >= 21 % within CI"
                else f"not reproduced ({head})"
            )
            out.append(
                {
                    **base,
                    "claim": "C3",
                    "speed": _speed(ref),
                    "numbers": nums,
                    "verdict": v,
                    "finding": f"{_g(_speed(ref))} m/s, best cell vs rigid: " + "; ".join(parts),
                }
            )
            # C4: how much the spine matters at low speed against 0.9 m/s
            if low is None:
                out.append({**base, "claim": "C4", "finding": "no low-speed cells", "verdict": "not tested"})
                continue
            spread = {}

            def cells_of(p: dict, spine: str = spine) -> list[dict]:
                return [
                    r
                    for r in rows_by_cell
                    if r["panel"] == p["panel"]
                    and r["spine"] == spine
                    and r["metric"] == HEADLINE
                    and r["diff_pct"] is not None
                ]

            # the same (k, d) cells at both speeds, so the two ranges are comparable
            common = {(r["k"], r["d"]) for r in cells_of(low)} & {(r["k"], r["d"]) for r in cells_of(ref)}
            for name, p in (("low", low), ("ref", ref)):
                cs = [r for r in cells_of(p) if (r["k"], r["d"]) in common]
                if not cs:
                    spread[name] = None
                    continue
                ds = [r["diff_pct"] for r in cs]
                sig = sum(
                    1 for r in cs if r["diff_lo"] is not None and (r["diff_lo"] > 0 or r["diff_hi"] < 0)
                )
                spread[name] = {
                    "min": min(ds),
                    "max": max(ds),
                    "range": max(ds) - min(ds),
                    "significant": sig,
                    "cells": len(cs),
                    "trials_fell": sum(r["n_fell"] for r in cs),
                    "trials": sum(r["n"] for r in cs),
                }
            if spread["low"] is None or spread["ref"] is None:
                out.append({**base, "claim": "C4", "finding": "cells fell", "verdict": "not tested"})
                continue
            lo_r, ref_r = spread["low"]["range"], spread["ref"]["range"]
            v = "reproduced" if lo_r < 0.5 * ref_r else "not reproduced"
            out.append(
                {
                    **base,
                    "claim": "C4",
                    "low_speed": _speed(low),
                    "spread": spread,
                    "verdict": v,
                    "finding": f"% vs rigid over k x d: {_g(_speed(low))} m/s {spread['low']['min']:+.0f} to "
                    f"{spread['low']['max']:+.0f} ({spread['low']['significant']}/"
                    f"{spread['low']['cells']} cells CI excludes 0; {spread['low']['trials_fell']}/"
                    f"{spread['low']['trials']} trials fell); {_g(_speed(ref))} m/s "
                    f"{spread['ref']['min']:+.0f} to {spread['ref']['max']:+.0f} "
                    f"({spread['ref']['significant']}/{spread['ref']['cells']}; "
                    f"{spread['ref']['trials_fell']}/{spread['ref']['trials']} fell)",
                }
            )
    return out


CLAIM_TEXT = {
    "C1": "flat-ground optimum k 800-1200 N/m",
    "C2": "lowest CoT at 500-800 N/m, 8-20 N·s/m, 70-80 mm strides",
    "C3": "21 % less power at 0.9 m/s than rigid",
    "C4": "insensitive to the spine at low speed",
}
RULES = (
    "C1: reproduced if the best cell (lowest mean CoT_pos among the cells with the fewest falls; CoT over "
    "the seeds that did not fall) has k_x in 800-1200 and so does every cell not distinguishable from it "
    "(its seed-paired difference to the best has a CI reaching 0). "
    "C2: k_x, d_x and the stride length of that best cell each in the claimed range. "
    "C3: the best cell's difference against rigid, paired by seed, has a 95 % CI below 0 that reaches -21 % "
    "(judged on CoT_pos; CoT_abs, CoT_net, CoT_elec shown beside it). "
    "C4: the range of % against rigid over the k x d cells at the low speed is under half of that at 0.9 m/s "
    "(the same cells at both speeds)."
)


def markdown(rows: list[dict]) -> str:
    lines = ["| claim (authors) | gait | spine | this study (95 % CI) | verdict |", "|---|---|---|---|---|"]
    for r in sorted(rows, key=lambda r: (r["claim"], r["gait"], r["spine"])):
        lines.append(
            f"| {r['claim']}: {CLAIM_TEXT[r['claim']]} | {r['gait']} | {r['spine']} | {r['finding']} | "
            f"{r['verdict']} |"
        )
    return "\n".join(lines) + "\n\nRules: " + RULES + "\n"
