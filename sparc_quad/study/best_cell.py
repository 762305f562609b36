"""Which cell of a set is best: the rule every judgement of the report and the claims uses."""

from __future__ import annotations

from sparc_quad.study.stats import falls_more, paired_difference

BASELINES = ("rigid", "rigid-impedance")
# what a spine is fairly compared with: a motor-rendered one with the same actuator made stiff, a
# passive spring-damper with the locked joint
BASELINE_OF = {"impedance": "rigid-impedance", "passive": "rigid"}


def best_of(cs: list, n_boot: int = 400) -> tuple:
    """Of report `Cell`s: the lowest-mean cell among those on speed that do not fall more often than
    the least-falling one (Newcombe interval of the rate difference above 0), the cells not
    distinguishable from it (their seed-paired difference has an interval reaching 0), and what was
    left out and why."""
    rated = [c for c in cs if c.est is not None]
    left_out = {"off_speed": [c for c in rated if c.off_speed], "all_fell": [c for c in cs if c.est is None]}
    on = [c for c in rated if not c.off_speed]
    if not on:
        return None, [], {**left_out, "fall_more": []}
    safest = min(on, key=lambda c: c.n_fell / c.n)
    good = [c for c in on if not falls_more(c.n_fell, c.n, safest.n_fell, safest.n)]
    left_out["fall_more"] = [c for c in on if c not in good]
    best = min(good, key=lambda c: c.est.value)
    near = []
    for c in good:
        diff = None if c is best else paired_difference(c.seeds, best.seeds, n_boot=n_boot)
        if c is best or diff is None or diff.overlaps(0.0) or (diff.lo is not None and diff.lo <= 0.0):
            near.append(c)
    return best, near, left_out
