"""Seeds are replicates (small perturbations); actuator latency is a study factor, never a seed."""

from __future__ import annotations

import pytest

from sparc_quad.sim.seed_variation import FRICTION, MASS_SCALE, Perturbation, perturbation
from sparc_quad.study.spec import SpecError, parse_spec
from sparc_quad.study.trial import bound_config


def test_seed_perturbations_are_small_and_carry_no_latency():
    ps = [perturbation(s) for s in range(1, 40)]
    assert all(MASS_SCALE[0] <= p.mass_scale <= MASS_SCALE[1] for p in ps)
    assert MASS_SCALE == (0.98, 1.02) and FRICTION == (0.9, 1.1)
    assert all(FRICTION[0] <= p.friction <= FRICTION[1] for p in ps)
    assert len({p.start_phase_cycles for p in ps}) == len(ps)  # every seed its own start phase
    assert not hasattr(Perturbation(), "latency_steps")
    assert perturbation(0) == Perturbation()


def test_latency_is_a_factor_default_zero():
    for seed in range(12):
        assert bound_config({"gait": "raibert", "seed": seed}).actuator_latency_steps == 0
    assert bound_config({"gait": "raibert", "seed": 3, "latency_steps": 2}).actuator_latency_steps == 2
    with pytest.raises(ValueError, match="latency_steps"):
        bound_config({"gait": "raibert", "latency_steps": -1})
    spec = parse_spec({"study": {"gait": "raibert", "duration": 1.0, "seeds": 2},
                       "grid": {"spine": ["rigid"], "latency_steps": [0, 2]}})
    assert sorted({c["latency_steps"] for c in spec.trials()}) == [0, 2]
    with pytest.raises(SpecError, match="latency_steps"):
        parse_spec({"study": {"gait": "raibert", "duration": 1.0}, "grid": {"latency_steps": [1.5]}})
