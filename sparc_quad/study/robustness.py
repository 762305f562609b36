"""Robustness beside cost: the gait frequencies each spine survives.

Why: a spine can cost no less and still be worth having if the gait tolerates more frequencies with it
(the stiff spines' window is narrower under the authors' gait A, issue 30). When a study's panels differ
only in the gait's `frequency` (the adaptation off), each spine cell gets, per frequency, its fall rate
with a Wilson interval and its mean speed; its window is the frequencies where at least
`best_cell.MIN_STANDING_SHARE` of its seeds stood, and "contiguous" says whether they form one interval.
"""

from __future__ import annotations

from collections import Counter, defaultdict

from sparc_quad.study.best_cell import MIN_STANDING_SHARE
from sparc_quad.study.stats import power_statement

FREQUENCY = "frequency"


def _g(x) -> str:
    return "–" if x is None else f"{x:g}"


def frequency_windows(analysis: dict, metric: str = "cot_pos_total") -> list[dict]:
    """One row per (family, spine, k, d): the frequencies run, the fall rate and speed at each, the window.
    A family is a set of panels whose configs differ only in `frequency`."""
    panels = {p["panel"]: p for p in analysis["panels"]}
    families: dict[tuple, dict[str, float]] = defaultdict(dict)
    for name, p in panels.items():
        f = p["config"].get(FREQUENCY)
        if isinstance(f, int | float):
            fam = tuple(sorted((k, v) for k, v in p["config"].items() if k != FREQUENCY))
            families[fam][name] = float(f)
    rows = []
    for fam, freq_of in sorted(families.items(), key=repr):
        if len(freq_of) < 2:
            continue
        cells: dict[tuple, list] = defaultdict(list)
        for c in analysis["cells"]:
            if c.metric == metric and c.panel in freq_of:
                cells[(c.spine, c.k, c.d)].append(c)
        for (spine, k, d), cs in sorted(cells.items(), key=repr):
            cs = sorted(cs, key=lambda c: freq_of[c.panel])
            points = [{"frequency_hz": freq_of[c.panel], "n": c.n, "n_fell": c.n_fell,
                       "fall_rate": c.fall_rate, "fall_lo": c.fall_lo, "fall_hi": c.fall_hi,
                       "speed_m_s": c.extras.get("speed_m_s")} for c in cs]
            ok = [p["frequency_hz"] for p in points if p["n"] and (p["n"] - p["n_fell"]) / p["n"]
                  >= MIN_STANDING_SHARE]
            idx = [i for i, p in enumerate(points) if p["frequency_hz"] in ok]
            rows.append({
                "family": dict(fam), "spine": spine, "k": k, "d": d, "points": points,
                "window_hz": [min(ok), max(ok)] if ok else None,
                "contiguous": bool(idx) and idx == list(range(idx[0], idx[-1] + 1)),
                "frequencies_standing": len(ok), "frequencies_run": len(points),
            })
    return rows


def markdown(rows: list[dict]) -> str:
    """The windows as a table: one row per spine cell, one column per frequency (fell/n)."""
    if not rows:
        return ""
    freqs = sorted({p["frequency_hz"] for r in rows for p in r["points"]})
    head = "| spine | k_x (N/m) | d_x (N·s/m) | " + " | ".join(f"{f:g} Hz" for f in freqs) + \
        f" | window (>= {MIN_STANDING_SHARE:.0%} standing) |"
    lines = [
        "# Frequency window: the gait frequencies each spine survives",
        "",
        "Each entry: trials fallen / trials run at that frequency (Wilson 95 % interval of the fall rate),"
        " and the mean speed of the standing seeds, m/s. The window is the frequencies where at least "
        f"{MIN_STANDING_SHARE:.0%} of the seeds stood.",
        "",
        power_statement(Counter(p["n"] for r in rows for p in r["points"]).most_common(1)[0][0]),
        "",
        head,
        "|" + "---|" * (4 + len(freqs)),
    ]
    for r in rows:
        at = {p["frequency_hz"]: p for p in r["points"]}
        cols = []
        for f in freqs:
            p = at.get(f)
            if p is None:
                cols.append("–")
                continue
            v = p["speed_m_s"]
            cols.append(f"{p['n_fell']}/{p['n']} [{100 * p['fall_lo']:.0f}-{100 * p['fall_hi']:.0f} %]"
                        + (f", {v:.2f}" if v is not None else ""))
        w = r["window_hz"]
        win = "none" if w is None else f"{w[0]:g}-{w[1]:g} Hz" + ("" if r["contiguous"] else " (with gaps)")
        lines.append(f"| {r['spine']} | {_g(r['k'])} | {_g(r['d'])} | " + " | ".join(cols) + f" | {win} |")
    return "\n".join(lines) + "\n"
