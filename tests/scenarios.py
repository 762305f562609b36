"""Scenarios the tests run often, built as every run is: a `Scenario` through `bound_config`."""

from __future__ import annotations

from dataclasses import replace

from sparc_quad.scenario import Scenario, bound_config


def authors_config(step_length_m: float = 0.12, k_x_n_m: float = 800.0, duration_s: float = 20.0,
                   engine: str = "mujoco", **keys):
    """Gait A as the authors run it on their dog (the scenario's defaults for sine on spined-dog) at their
    released step length, stopped at a fall and judged from their spine switch (settle 0), as their
    comparisons in tests/reference use it."""
    s = Scenario(host="spined-dog", gait="sine", engine=engine, step_length=step_length_m, kx=k_x_n_m,
                 duration=duration_s, settle=0.0, **keys)
    return replace(bound_config(s), stop_on_fall=True)


def trial_config(config: dict):
    """A study trial config's simulator configuration (what `sparc_quad.study.trial` runs)."""
    from sparc_quad.study.trial import config_of

    return config_of(config)
