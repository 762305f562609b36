"""One trial of the spine stiffness study: `run_trial(config) -> metrics`, a pure function.

Pure: its own pybullet client, its own seeded generators, nothing written, so a study can fan trials out
over processes or a Dask cluster and cache them by config. The config is a flat dict:

- `gait`: "sine" (family A, the authors' open-loop bound), "raibert" (the project's Raibert bound),
  "raibert-opt" (family B: Raibert re-optimised with CMA-ES for this cell, see `raibert_opt`);
- `spine`: "impedance" | "passive" | "rigid" | "rigid-impedance" (sparc_quad.sim.spine_drive);
- `duration` (s), `seed` (int; sparc_quad.sim.seed_variation: 0 is nominal), `slope` (rad, > 0 uphill);
- `speed` (m/s, raibert target), and `sparc-quad bound` options in snake_case: `kx kz kth dx dz dth`,
  `frequency duty step_height stride`; gait A also `step_length adapt_frequency spine_rate_hz schedule`.

The result is a flat dict of floats/bools/str (NaN where undefined) plus `strides`, a list of per-stride
dicts with the same metric names where meaningful (sparc_quad.metrics.TABLE).
"""

from __future__ import annotations

from sparc_quad.study.fixed_trial import GAITS, bound_config, check_config, run_fixed_trial, spine_gains
from sparc_quad.study.raibert_opt import run_optimised_trial

__all__ = ["GAITS", "bound_config", "check_config", "run_trial", "spine_gains"]


def run_trial(config: dict) -> dict:
    """Run one trial; flat metrics + `strides`. Raises ValueError on a bad config (naming the key)."""
    if config.get("gait") == "raibert-opt":
        return run_optimised_trial(config)
    return run_fixed_trial(config)
