"""sparc-quad: the SPARC spine integrated into a simulated quadruped, with the paper's experiments.

The Python API (docs/api.md): `Scenario` describes a bound, `run_bound` runs it, `write_outputs` writes
what `sparc-quad bound` writes; `run_study` and `run_gap` run a study spec and the gap workflow. They are
imported on first use, so `import sparc_quad` on the robot (no simulator installed) costs nothing.
"""

from __future__ import annotations

__version__ = "0.1.0"
__all__ = ["Scenario", "ScenarioError", "__version__", "bound_config", "load_scenario", "run_bound",
           "run_gap", "run_study", "write_outputs"]

_FROM = {"Scenario": "sparc_quad.scenario", "ScenarioError": "sparc_quad.scenario",
         "bound_config": "sparc_quad.scenario", "load_scenario": "sparc_quad.scenario",
         "run_bound": "sparc_quad.api", "write_outputs": "sparc_quad.api", "run_study": "sparc_quad.api",
         "run_gap": "sparc_quad.api"}


def __getattr__(name: str):
    if name in _FROM:
        import importlib

        return getattr(importlib.import_module(_FROM[name]), name)
    raise AttributeError(f"module 'sparc_quad' has no attribute {name!r}")
