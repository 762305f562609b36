"""One trial of the spine stiffness study: `run_trial(config) -> metrics`, a pure function.

Pure: its own pybullet client, its own seeded generators, nothing written, so a study can fan trials out
over processes or a Dask cluster and cache them by config. The config is a flat dict:

- `gait`: "sine" (family A, the authors' open-loop bound), "raibert" (the project's Raibert bound),
  "raibert-opt" (family B: Raibert re-optimised with CMA-ES for this cell, see `raibert_opt`);
- `match_speed` (m/s) and the other `speed_match.MATCH_KEYS`: the cell's command, frequency or step length
  calibrated until it runs that speed (see `speed_match`);
- `spine`: "impedance" | "passive" | "rigid" | "rigid-impedance" (sparc_quad.sim.spine_drive);
- `duration` (s), `seed` (int; sparc_quad.sim.seed_variation: 0 is nominal), `slope` (rad, > 0 uphill);
- `speed` (m/s, raibert target), and `sparc-quad bound` options in snake_case: `kx kz kth dx dz dth`,
  `frequency duty step_height stride`; gait A also `step_length adapt_frequency spine_rate_hz schedule`.

The result is a flat dict of floats/bools/str (NaN where undefined) plus `strides`, a list of per-stride
dicts with the same metric names where meaningful (sparc_quad.metrics.TABLE).
"""

from __future__ import annotations

from sparc_quad.study.fixed_trial import GAITS, config_of, run_fixed_trial, scenario_of, trial_scenario
from sparc_quad.study.fixed_trial import check_config as check_fixed
from sparc_quad.study.raibert_opt import check_search, run_optimised_trial
from sparc_quad.study.speed_match import check_match, is_matched, matched_scenario_config, run_matched_trial

__all__ = ["GAITS", "check_config", "config_of", "run_trial", "scenario_of", "trial_scenario"]


def check_config(config: dict) -> None:
    """ValueError naming the first bad key of a trial config (any gait)."""
    if isinstance(config, dict) and config.get("gait") == "raibert-opt":
        check_search(config)
    elif is_matched(config):
        check_match(config)
    else:
        check_fixed(config)


def run_trial(config: dict) -> dict:
    """Run one trial; flat metrics + `strides`. Raises ValueError on a bad config (naming the key)."""
    if config.get("gait") == "raibert-opt":
        return run_optimised_trial(config)
    if is_matched(config):
        return run_matched_trial(config)
    return run_fixed_trial(config)


def record_scenario(config: dict, metrics: dict) -> dict | None:
    """The resolved scenario of a finished trial, for its record (`sparc-quad bound --scenario` re-runs
    it): the config's own for a fixed gait; for raibert-opt the reported trial's (the cell's base with the
    tuned gait parameters, `opt_<key>` in its metrics)."""
    if config.get("gait") == "raibert-opt":
        from sparc_quad.study.raibert_opt import OPT_KEYS, SEARCH

        base = {k: v for k, v in config.items() if k not in OPT_KEYS}
        tuned = {k: metrics[f"opt_{k}"] for k, _, _ in SEARCH if f"opt_{k}" in metrics}
        config = {**base, "gait": "raibert", **tuned}
    elif is_matched(config):
        config = matched_scenario_config(config, metrics)
    return trial_scenario(config).to_dict()
