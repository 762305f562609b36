"""Gait family B ("raibert-opt"): the Raibert bound re-tuned for each spine cell with CMA-ES (`cma`).

Why: a gait tuned for one spine (or none) favours that spine. Here each (spine variant, k, d, speed,
slope) cell gets its own gait: CMA-ES searches frequency, duty, front/hind phase offset, step height and
the stance attitude servo's gains (`body_kp`, `body_kd`, which push against spine flexion) to minimise
CoT_pos, with a penalty when the trial falls or misses the target speed by more than 0.03 m/s. Stride
length is emergent: the speed servo holds the target, so stride = speed / frequency.

Converged, as a referee would check: every evaluation lasts >= 6 s so its metric window (the second half)
lies after the speed ramp, and the objective is the judged metric (CoT_pos) itself; CMA-ES runs from
`opt_restarts` optimiser seeds, each candidate judged over `opt_trial_seeds` perturbation seeds (1..n,
not the reported trial's seed); the rigid spines get the same search as every other cell. Budget:
`opt_restarts` x `popsize` x `iterations` candidates, each `opt_trial_seeds` trials of `opt_duration` s.
The convergence record (`opt_convergence`, best objective after each evaluation, and
`opt_objective_at_half_budget`) says whether the budget was enough: the best objective should move less
at the second half than the CI of the reported CoT. Then the reported trial at the config's own duration
and seed with the best gait. Deterministic: CMA-ES is seeded,
so the same cell gives the same gait in any process; `optimise_cell(config)` is what a study caches (by
`cell_key(config)`), and a config carrying `tuned` (the dict it returns) skips the search.
"""

from __future__ import annotations

import json
import math
import warnings
from functools import lru_cache

import numpy as np

from sparc_quad.scenario.model import DURATION_MAX_S
from sparc_quad.study.fixed_trial import check_config
from sparc_quad.study.fixed_trial import run_fixed_trial as run_trial

# (config key, lower, upper): the search box; CMA works on [0, 1]^n mapped into it
SEARCH = (
    ("frequency", 2.5, 5.0),  # Hz
    ("duty", 0.3, 0.6),
    ("phase_offset", 0.3, 0.7),  # front stance starts this fraction of a stride after the hind
    ("step_height", 0.03, 0.10),  # m
    ("body_kp", 0.0, 12.0),  # N*m/rad
    ("body_kd", 0.0, 1.2),  # N*m*s/rad
)
SPEED_TOLERANCE_M_S = 0.03
FALL_PENALTY = 10.0
SPEED_PENALTY_PER_M_S = 50.0
OBJECTIVE = "cot_pos_total"  # the metric the study judges
MIN_EVAL_S = 6.0  # an evaluation is judged after the start-up ramp: window in its second half at least
MAX_EVALUATIONS = 10_000  # simulated trials of one cell's search
OPT_KEYS = ("popsize", "iterations", "opt_duration", "opt_seed", "opt_restarts", "opt_trial_seeds", "tuned")
_CELL_SKIP = ("seed", "duration", "tuned")


def cell_key(config: dict) -> tuple:
    """What the tuned gait depends on: everything but the seed, the duration and a supplied `tuned`."""
    return tuple(sorted((k, v) for k, v in config.items() if k not in _CELL_SKIP))


def _decode(u: np.ndarray) -> dict:
    u = np.clip(u, 0.0, 1.0)
    return {k: float(lo + (hi - lo) * x) for (k, lo, hi), x in zip(SEARCH, u, strict=True)}


def objective(metrics: dict, target_speed: float, duration: float) -> float:
    """The judged metric (OBJECTIVE), plus penalties: a fall (more the earlier), a mean speed off target by
    > 0.03 m/s."""
    cot = metrics.get(OBJECTIVE, float("nan"))
    f = cot if isinstance(cot, float) and math.isfinite(cot) and cot > 0 else FALL_PENALTY
    if metrics.get("fell"):
        t = metrics.get("fall_time_s") or 0.0
        f += FALL_PENALTY * (1.0 + (duration - t) / duration)
    v = metrics.get("speed_m_s", float("nan"))
    err = abs(v - target_speed) if isinstance(v, float) and math.isfinite(v) else 1.0
    if err > SPEED_TOLERANCE_M_S:
        f += SPEED_PENALTY_PER_M_S * (err - SPEED_TOLERANCE_M_S)
    return float(f)


def _base(config: dict) -> dict:
    base = {k: v for k, v in config.items() if k not in OPT_KEYS}
    base["gait"] = "raibert"
    check_config(base)
    return base


def check_search(config: dict) -> None:
    """ValueError naming a bad search key (counts, evaluation time) or a bad base scenario."""
    for key, default, least in (("popsize", 6, 2), ("iterations", 5, 1), ("opt_restarts", 2, 1),
                                ("opt_trial_seeds", 2, 1), ("opt_seed", 0, 0)):
        v = config.get(key, default)
        if isinstance(v, bool) or not isinstance(v, int) or v < least:
            raise ValueError(f"{key}: must be an integer >= {least}, got {v!r}")
    if int(config.get("popsize", 6)) * int(config.get("iterations", 5)) * int(config.get("opt_restarts", 2)) \
            * int(config.get("opt_trial_seeds", 2)) > MAX_EVALUATIONS:
        raise ValueError(f"popsize x iterations x opt_restarts x opt_trial_seeds: at most {MAX_EVALUATIONS} "
                         "evaluations per cell")
    d = config.get("opt_duration", MIN_EVAL_S)
    if isinstance(d, bool) or not isinstance(d, int | float) or not MIN_EVAL_S <= d <= DURATION_MAX_S:
        raise ValueError(f"opt_duration: must be in [{MIN_EVAL_S:g}, {DURATION_MAX_S:g}] s (judged after the "
                         f"start-up ramp), got {d!r}")
    tuned = config.get("tuned")
    if tuned is not None and not isinstance(tuned, dict):
        raise ValueError(f"tuned: must be a table of gait parameters, got {tuned!r}")
    _base(config)


def optimise_cell(config: dict) -> dict:
    """The tuned gait parameters of this cell (a dict of `raibert` config keys) + search statistics."""
    return dict(_optimise(cell_key(config)))


@lru_cache(maxsize=32)
def _optimise(key: tuple) -> tuple:
    """CMA-ES from `opt_restarts` optimiser seeds, each candidate judged by its mean objective over
    `opt_trial_seeds` perturbation seeds (1..n); the best over all restarts, and the best-so-far objective
    after every evaluation (the convergence record)."""
    import cma

    config = dict(key)
    check_search(config)
    popsize = int(config.get("popsize", 6))
    iterations = int(config.get("iterations", 5))
    restarts = int(config.get("opt_restarts", 2))
    trial_seeds = int(config.get("opt_trial_seeds", 2))
    duration = float(config.get("opt_duration", MIN_EVAL_S))
    seed = int(config.get("opt_seed", 0))
    base = _base(config)
    target = float(base.get("speed", 0.6))
    best_f, best_x, curve = math.inf, None, []
    window_start = math.nan
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # short evaluation windows are expected
        for r in range(restarts):
            es = cma.CMAEvolutionStrategy(
                [0.5] * len(SEARCH), 0.25,
                {"popsize": popsize, "maxiter": iterations, "bounds": [0.0, 1.0], "seed": 13 + seed + 7 * r,
                 "verbose": -9},
            )
            while not es.stop():
                xs = es.ask()
                fs = []
                for x in xs:
                    runs = [run_trial({**base, **_decode(np.asarray(x)), "duration": duration, "seed": s})
                            for s in range(1, trial_seeds + 1)]
                    window_start = float(runs[0].get("window_s_0", math.nan))
                    f = float(np.mean([objective(m, target, duration) for m in runs]))
                    fs.append(f)
                    if f < best_f:
                        best_f, best_x = f, np.asarray(x)
                    curve.append(best_f)
                es.tell(xs, fs)
    tuned = _decode(best_x)
    half = curve[len(curve) // 2 - 1] if len(curve) >= 2 else best_f
    stats = {"_objective": best_f, "_evaluations": len(curve), "_objective_at_half_budget": half,
             "_window_start_s": window_start, "_convergence": tuple(curve)}
    return tuple(sorted({**tuned, **stats}.items()))


def run_optimised_trial(config: dict) -> dict:
    """Tune (or take `tuned`), then run the reported trial; its metrics + `opt_*` keys."""
    tuned = config.get("tuned")
    if tuned is None:
        tuned = optimise_cell(config)
    elif not isinstance(tuned, dict):
        raise ValueError(f"config 'tuned' must be a dict of gait parameters, got {tuned!r}")
    params = {k: v for k, v in tuned.items() if not k.startswith("_")}
    bad = sorted(set(params) - {k for k, _, _ in SEARCH})
    if bad:
        raise ValueError(f"config 'tuned' has unknown key(s): {', '.join(bad)}")
    base = _base(config)
    m = run_trial({**base, **params})
    m["gait"] = "raibert-opt"
    for k, v in tuned.items():
        if k == "_convergence":  # best objective after each evaluation, one JSON list
            m["opt_convergence"] = json.dumps([round(float(x), 6) for x in v])
        else:
            m[f"opt{k}" if k.startswith("_") else f"opt_{k}"] = float(v)
    return m
