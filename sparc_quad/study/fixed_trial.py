"""A trial with fixed gait parameters: a study cell's keys as a `Scenario`, and its run.

A trial config is a flat dict of scenario keys (`sparc_quad.scenario.KEYS`: the `sparc-quad bound` options
in snake_case), with `gait = "raibert-opt"` adding the search keys of `raibert_opt`. The scenario is the
same one `sparc-quad bound` builds from the same keys, so a study trial is what `bound` runs
(`bound --scenario <record>.json` re-runs it).
"""

from __future__ import annotations

from sparc_quad.bound.run import BoundConfig, run_bound
from sparc_quad.metrics import merge_disjoint
from sparc_quad.scenario import KEYS, Scenario, ScenarioError, bound_config, resolved, spine_of
from sparc_quad.sim.seed_variation import perturbation

GAITS = (*KEYS["gait"].choices, "raibert-opt")  # a study's gaits: a scenario's, and the tuned Raibert bound


def scenario_of(config: dict) -> Scenario:
    """The scenario of a trial config; ValueError (a ScenarioError) naming the first bad key."""
    if not isinstance(config, dict):
        raise ScenarioError(None, f"config must be a dict, got {type(config).__name__}")
    return Scenario.from_dict(config)


def check_config(config: dict) -> None:
    """Raise ValueError naming the first bad key or value (the scenario's own checks, plus gait A's foot
    targets)."""
    bound_config(scenario_of(config))


def trial_scenario(config: dict) -> Scenario:
    """The resolved scenario a trial config runs (what its record stores)."""
    return resolved(scenario_of(config))


def config_of(config: dict) -> BoundConfig:
    """The simulator's configuration of a trial config (seed perturbation applied)."""
    return bound_config(scenario_of(config))


def _flat(metrics: dict) -> dict:
    out: dict = {}
    for k, v in metrics.items():
        if k == "strides":
            continue
        if isinstance(v, dict):
            for kk, vv in _flat(v).items():
                out[f"{k}_{kk}"] = vv
        elif isinstance(v, list | tuple):
            for i, vv in enumerate(v):
                out[f"{k}_{i}"] = float("nan") if vv is None else vv
        elif v is None:
            out[k] = float("nan")
        else:
            out[k] = v
    return out


def run_fixed_trial(config: dict) -> dict:
    """One trial with the gait parameters as given (gait A, or the Raibert bound untuned)."""
    scenario = scenario_of(config)
    cfg = bound_config(scenario)
    result = run_bound(cfg, spine=spine_of(scenario, cfg))  # spine_path node: the node, as `bound` runs it
    m = result.metrics
    out = merge_disjoint(_flat({k: v for k, v in m.items() if k != "strides"}),
                         perturbation(int(config.get("seed", 0))).as_metrics())
    out["strides"] = m["strides"]
    out["gait"] = config.get("gait", "raibert")
    out["spine"] = config.get("spine", "impedance")
    out["fall_reason"] = m.get("fall_reason") or ""
    return out
