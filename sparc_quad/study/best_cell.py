"""Which cell of a set is best: the rule every judgement of the report and the claims uses.

- A cell is judged only if it ran at least `MIN_SEEDS` seeds: else "not tested (n < minimum)", listed apart
  (`few_seeds`). Eight, because (a) it is `MIN_STANDING_SHARE` of the 10 seeds the studies plan, so one
  number states both gates; (b) 8 = 2 x `MIN_SPLIT_SEEDS`: the best cell can be chosen on one half of the
  seeds and estimated on the other (winner's curse); (c) at 8 seeds the t quantile (df 7, 2.36) is 20 %
  above the normal's 1.96, at 3 seeds (df 2, 4.30) 119 % above, and one seed has no between-seed
  interval at all (a trial of 4 s, the README's tour, is one window value: nothing to judge).
- Of those, at least `MIN_STANDING_SHARE` of its seeds, and at least `MIN_SEEDS`, must stand: else "not
  tested (falls)", listed apart; comparisons between cells are conditional on survival, so a cell where
  most seeds fell is not scored from its survivors.
- It must not fall more often than the least-falling judged cell (Newcombe interval of the rate difference
  above 0).
- Split sample: when every ranked cell has at least `MIN_SPLIT_SEEDS` seeds, the best cell is chosen on the
  even seeds and every interval about it (near-best set, difference to a baseline) is computed on the odd
  seeds only, so picking the minimum of many noisy cells does not bias its estimate (winner's curse). With
  fewer seeds the choice and the estimate share the seeds, and the report says so.
"""

from __future__ import annotations

import numpy as np

from sparc_quad.study.stats import falls_more, paired_difference

BASELINES = ("rigid", "rigid-impedance")
# what a spine is fairly compared with: a motor-rendered one with the same actuator made stiff, a
# passive spring-damper with the locked joint
BASELINE_OF = {"impedance": "rigid-impedance", "passive": "rigid"}
MIN_STANDING_SHARE = 0.8
MIN_SPLIT_SEEDS = 4
MIN_SEEDS = 2 * MIN_SPLIT_SEEDS  # the minimum n of a judged cell (module docstring): 8
NOT_TESTED_N = "not tested (n < minimum)"
SELECTION_SPLIT = "chosen on the even seeds, estimated on the odd seeds"
SELECTION_SHARED = "chosen and estimated on the same seeds (too few seeds to split)"


def select_seeds(seeds: dict) -> dict:
    """The seeds a best cell is chosen on (even)."""
    return {s: v for s, v in seeds.items() if s % 2 == 0}


def held_out(seeds: dict) -> dict:
    """The seeds a chosen cell is estimated on (odd)."""
    return {s: v for s, v in seeds.items() if s % 2 == 1}


def enough_seeds(c) -> bool:
    """Whether the cell ran enough seeds to be judged at all (`MIN_SEEDS`)."""
    return c.n >= MIN_SEEDS


def stands(c) -> bool:
    """Whether the cell ran enough seeds and enough of them stood to judge it."""
    standing = c.n - c.n_fell
    return enough_seeds(c) and standing >= max(MIN_SEEDS, MIN_STANDING_SHARE * c.n - 1e-9)


def _mean(seeds: dict) -> float:
    per_seed = [float(np.mean(v)) for v in seeds.values() if len(v)]
    return float(np.mean(per_seed)) if per_seed else float("inf")


def best_of(cs: list, n_boot: int = 400) -> tuple:
    """Of report `Cell`s: the best cell (lowest mean), the cells not distinguishable from it (their
    seed-paired difference has an interval reaching 0) and what was left out and why; `left["selection"]`
    says whether the choice and the estimate used different seeds (module docstring)."""
    rated = [c for c in cs if c.est is not None]
    left_out = {"off_speed": [c for c in rated if c.off_speed], "all_fell": [c for c in cs if c.est is None],
                "few_seeds": [c for c in rated if not c.off_speed and not enough_seeds(c)],
                "falls": [c for c in rated if not c.off_speed and enough_seeds(c) and not stands(c)]}
    on = [c for c in rated if not c.off_speed and stands(c)]
    if not on:
        return None, [], {**left_out, "fall_more": [], "selection": None}
    safest = min(on, key=lambda c: c.n_fell / c.n)
    good = [c for c in on if not falls_more(c.n_fell, c.n, safest.n_fell, safest.n)]
    left_out["fall_more"] = [c for c in on if c not in good]
    split = all(len(c.seeds) >= MIN_SPLIT_SEEDS for c in good)
    pick, judge = (select_seeds, held_out) if split else (dict, dict)
    left_out["selection"] = SELECTION_SPLIT if split else SELECTION_SHARED
    best = min(good, key=lambda c: _mean(pick(c.seeds)))
    near = []
    for c in good:
        diff = None if c is best else paired_difference(judge(c.seeds), judge(best.seeds), n_boot=n_boot)
        if c is best or diff is None or diff.overlaps(0.0) or (diff.lo is not None and diff.lo <= 0.0):
            near.append(c)
    return best, near, left_out
