"""Speed matched by design: each study cell's gait input tuned until the cell runs the target speed.

Why: comparing costs "at 0.9 m/s" needs every spine to run 0.9 m/s. Keeping only the cells that happen to
land near it filters on an outcome the spine changes; a speed-commanded controller that misses its command
(the authors' locked dog runs 0.83 m/s when told 0.9) leaves nothing to compare. Here the input that sets
the speed is calibrated per cell, the way a bench sets a treadmill: the command of a speed-commanded gait
(`match_by = "speed"`), or gait A's `frequency` or `step_length` with its adaptation off. The reported
seeds then run at the calibrated value and are judged against the target like any commanded cell.

Keys a trial config adds (`[scenario]` or `[grid]` of a spec):
  match_speed       the target mean speed over the judged window, m/s (the panel's speed)
  match_by          the scenario key tuned: speed | frequency | step_length
  match_tolerance   calibration stops within this of the target, m/s (default 0.01)
  match_seeds       calibration seeds, CALIBRATION_SEED0 .. + n - 1, disjoint from a study's reported
                    seeds so the value reported is not tuned on the trials that judge it (default 3)
  match_iterations  at most this many calibration points (default 6), each match_seeds trials long
  match_spread      the standing calibration seeds of a point must agree within this, m/s (default 0.1)
  matched           the calibration result (a study computes it once per cell and passes it on)

The calibration: a point is the mean speed over the calibration seeds that stand (a point where more than
half fall has no speed, nor one whose standing seeds' speeds span more than match_spread: a gait that is
bimodal by seed, some seeds bounding forward and others reversing, has a mean no seed runs; measured, gait C
in pybullet at a 0.5 m/s command ran 0.35, 0.55 and 0.60 m/s on the three seeds and "converged" on their
mean 0.503). Each point keeps its seeds' speeds. From the start value (the command at the target for
`speed`, else the gait's value), the next value scales by target / achieved (speed proportional to the
input, step at most x1.6) until the target is bracketed, then interpolates inside the bracket; inputs
that fell are searched around (`next_value`). The result is the point nearest the target, with `converged`
saying whether it is within the tolerance.
"""

from __future__ import annotations

import json
import math
from functools import lru_cache

import numpy as np

from sparc_quad.scenario import ScenarioError
from sparc_quad.study.fixed_trial import check_config as check_fixed
from sparc_quad.study.fixed_trial import run_fixed_trial, trial_scenario

MATCH_KEYS = ("match_speed", "match_by", "match_tolerance", "match_seeds", "match_iterations", "match_spread",
              "matched")
# the keys a calibration may tune and their search bounds (m/s, Hz, m)
BY_BOUNDS = {"speed": (0.05, 3.0), "frequency": (1.0, 6.0), "step_length": (0.02, 0.2)}
CALIBRATION_SEED0 = 1000
DEFAULTS = {"match_by": "speed", "match_tolerance": 0.01, "match_seeds": 3, "match_iterations": 6,
            "match_spread": 0.1}
MAX_STEP_RATIO = 1.6  # one proportional step changes the input by at most this factor
MAX_HALVINGS = 4  # a step onto an input that fell is halved back toward the last good one this often
_CELL_SKIP = ("seed", "matched")


def is_matched(config: dict) -> bool:
    return isinstance(config, dict) and "match_speed" in config


def _opt(config: dict, key: str):
    return config.get(key, DEFAULTS.get(key))


def base_of(config: dict) -> dict:
    """The cell's scenario keys (the match keys taken off)."""
    return {k: v for k, v in config.items() if k not in MATCH_KEYS}


def check_match(config: dict) -> None:
    """ValueError naming the first bad match key, or the scenario's own error."""
    t = config.get("match_speed")
    if isinstance(t, bool) or not isinstance(t, int | float) or not 0.0 < t <= 5.0:
        raise ValueError(f"match_speed: a target speed in (0, 5] m/s, got {t!r}")
    by = _opt(config, "match_by")
    if by not in BY_BOUNDS:
        raise ValueError(f"match_by: one of {', '.join(BY_BOUNDS)}, got {by!r}")
    tol = _opt(config, "match_tolerance")
    if isinstance(tol, bool) or not isinstance(tol, int | float) or not 0.0 < tol <= 0.5:
        raise ValueError(f"match_tolerance: in (0, 0.5] m/s, got {tol!r}")
    spread = _opt(config, "match_spread")
    if isinstance(spread, bool) or not isinstance(spread, int | float) or not 0.0 < spread <= 5.0:
        raise ValueError(f"match_spread: in (0, 5] m/s, got {spread!r}")
    for key, least, most in (("match_seeds", 1, 50), ("match_iterations", 1, 30)):
        v = _opt(config, key)
        if isinstance(v, bool) or not isinstance(v, int) or not least <= v <= most:
            raise ValueError(f"{key}: an integer in [{least}, {most}], got {v!r}")
    matched = config.get("matched")
    if isinstance(matched, dict) and "failed" in matched:
        raise ValueError(f"matched: this cell's speed calibration failed ({matched['failed']})")
    if matched is not None and not (isinstance(matched, dict) and "value" in matched):
        raise ValueError(f"matched: a calibration result with a 'value', got {matched!r}")
    base = base_of(config)
    check_fixed(base)
    gait = trial_scenario(base).gait
    if by == "speed" and gait not in ("raibert", "authors-raibert"):
        raise ValueError(f"match_by: 'speed' is a command only in the speed-commanded gaits; gait {gait} "
                         "matches by frequency or step_length")
    if by != "speed" and gait != "sine":
        raise ValueError(f"match_by: {by!r} is tuned in gait A (sine); gait {gait} matches by speed")
    if by in base:
        lo, hi = BY_BOUNDS[by]
        if not lo <= float(base[by]) <= hi:
            raise ValueError(f"{by}: the calibration's start value must be in [{lo:g}, {hi:g}], "
                             f"got {base[by]!r}")


def cell_key(config: dict) -> tuple:
    """What a calibration depends on: everything but the reported seed and a supplied result."""
    return tuple(sorted((k, v) for k, v in config.items() if k not in _CELL_SKIP))


def cell_config(config: dict) -> dict:
    return dict(cell_key(config))


def _start(config: dict, by: str) -> float:
    base = base_of(config)
    if by in base:
        return float(base[by])
    if by == "speed":
        return float(config["match_speed"])
    return float(getattr(trial_scenario(base), by))


def _point(base: dict, by: str, x: float, seeds: list[int], spread: float) -> tuple[float, int, list]:
    """Mean speed (m/s) over the standing calibration seeds at input x, how many fell, and each seed's speed
    (None: fell); NaN when more than half fell or the standing seeds span more than `spread` m/s."""
    speeds: list[float | None] = []
    for s in seeds:
        try:
            m = run_fixed_trial({**base, by: float(x), "seed": s})
        except ScenarioError:  # an input the gait cannot run (a foot target out of reach): no speed there
            return math.nan, 0, []
        v = m.get("speed_m_s", math.nan)
        standing = not m.get("fell") and isinstance(v, float) and math.isfinite(v)
        speeds.append(float(v) if standing else None)
    up = [v for v in speeds if v is not None]
    fell = len(speeds) - len(up)
    if fell * 2 > len(seeds) or not up or max(up) - min(up) > spread:
        return math.nan, fell, speeds
    return float(np.mean(up)), fell, speeds


def next_value(history: list[tuple[float, float]], target: float, lo: float, hi: float) -> float | None:
    """The next input to try from (input, mean speed) points, or None when nothing is left to try:
    - inside a bracket of the target, interpolation;
    - else a proportional step toward it (at most x MAX_STEP_RATIO), halved back toward the last good
      input while it lands on one that fell (gait A's locked spine at 0.9 m/s fell at L 80 mm, stood at
      50 mm, and 50-80 mm was never tried);
    - after a point without a speed (falls, or seeds that disagree), half way back to the nearest good one;
    - while no point has a speed, a step down by MAX_STEP_RATIO: a slower command or a shorter step is the
      gentler gait (gait A's locked spine fell at the default L 80 mm, and its 0.5 m/s calibration ended
      there)."""
    good = [(x, v) for x, v in history if math.isfinite(v)]
    last_x, last_v = history[-1]
    if not good:
        x = last_x / MAX_STEP_RATIO
    elif not math.isfinite(last_v):
        nearest = min(good, key=lambda p: abs(p[0] - last_x))[0]
        x = 0.5 * (last_x + nearest)
    else:
        below = [p for p in good if p[1] < target]
        above = [p for p in good if p[1] > target]
        if below and above:
            (xa, va) = min(below, key=lambda p: target - p[1])
            (xb, vb) = min(above, key=lambda p: p[1] - target)
            x = xa + (target - va) * (xb - xa) / (vb - va)
        else:
            x0, v0 = last_x, last_v
            ratio = target / v0 if v0 > 0 else MAX_STEP_RATIO
            x = x0 * min(MAX_STEP_RATIO, max(1.0 / MAX_STEP_RATIO, ratio))
    x = min(hi, max(lo, x))
    for _ in range(MAX_HALVINGS):
        hit = next((pv for px, pv in history if abs(x - px) <= 1e-6 * max(1.0, abs(px))), None)
        if hit is None:
            return float(x)
        if math.isfinite(hit) or not math.isfinite(last_v):
            return None  # that input has its speed already
        # the step lands on an input that fell: the edge lies between it and the last good input
        x = 0.5 * (x + last_x)
    return None


def calibrate(config: dict) -> dict:
    """The calibrated input of this config's cell (cached per cell in this process)."""
    return json.loads(_calibrate(json.dumps(cell_config(config), sort_keys=True)))


@lru_cache(maxsize=64)
def _calibrate(cell_json: str) -> str:
    config = json.loads(cell_json)
    check_match(config)
    by, target = _opt(config, "match_by"), float(config["match_speed"])
    tol, n_it = float(_opt(config, "match_tolerance")), int(_opt(config, "match_iterations"))
    spread = float(_opt(config, "match_spread"))
    seeds = [CALIBRATION_SEED0 + i for i in range(int(_opt(config, "match_seeds")))]
    base = base_of(config)
    lo, hi = BY_BOUNDS[by]
    x: float | None = min(hi, max(lo, _start(config, by)))
    history: list[tuple[float, float]] = []
    falls: list[int] = []
    per_seed: list[list] = []
    while x is not None and len(history) < n_it:
        v, nf, speeds = _point(base, by, x, seeds, spread)
        history.append((x, v))
        falls.append(nf)
        per_seed.append(speeds)
        if math.isfinite(v) and abs(v - target) <= tol:
            break
        x = next_value(history, target, lo, hi)
    good = [(abs(v - target), i) for i, (_, v) in enumerate(history) if math.isfinite(v)]
    i = min(good)[1] if good else len(history) - 1
    value, achieved = history[i]
    return json.dumps({
        "by": by,
        "target_m_s": target,
        "value": value,
        "achieved_m_s": achieved if math.isfinite(achieved) else None,
        "converged": bool(math.isfinite(achieved) and abs(achieved - target) <= tol),
        "tolerance_m_s": tol,
        "spread_m_s": spread,
        "seeds": seeds,
        # per point: input, mean speed (None: no speed), falls, each seed's speed (None: fell)
        "history": [[x_, v_ if math.isfinite(v_) else None, nf, sp]
                    for (x_, v_), nf, sp in zip(history, falls, per_seed, strict=True)],
    }, sort_keys=True)


def run_matched_trial(config: dict) -> dict:
    """Calibrate (or take `matched`), then run the reported seed at the calibrated input; its metrics and
    `match_*` keys saying what was tuned, to what, and how well."""
    check_match(config)
    result = config.get("matched") or calibrate(config)
    by = result.get("by", _opt(config, "match_by"))
    m = run_fixed_trial({**base_of(config), by: float(result["value"])})
    achieved = result.get("achieved_m_s")
    m.update({
        "match_by": by,
        "match_value": float(result["value"]),
        "match_target_m_s": float(config["match_speed"]),
        "match_calibration_speed_m_s": math.nan if achieved is None else float(achieved),
        "match_converged": bool(result.get("converged", False)),
        "match_points": len(result.get("history", ())),
        "match_history": json.dumps(result.get("history", [])),
    })
    return m


def matched_scenario_config(config: dict, metrics: dict) -> dict:
    """The scenario keys the reported trial ran (the calibrated input in place): what its record stores."""
    return {**base_of(config), metrics["match_by"]: metrics["match_value"]}
