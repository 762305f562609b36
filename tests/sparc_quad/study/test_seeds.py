"""Seeds are replicates (small perturbations); actuator latency is a study factor, never a seed."""

from __future__ import annotations

import pytest

from sparc_quad.sim.seed_variation import FRICTION, MASS_SCALE, Perturbation, perturbation
from sparc_quad.study.spec import SpecError, parse_spec
from tests.scenarios import authors_config
from tests.scenarios import trial_config as bound_config


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
    spec = parse_spec({"study": {"seeds": 2}, "scenario": {"gait": "raibert", "duration": 1.0},
                       "grid": {"spine": ["rigid"], "latency_steps": [0, 2]}})
    assert sorted({c["latency_steps"] for c in spec.trials()}) == [0, 2]
    with pytest.raises(SpecError, match="latency_steps"):
        parse_spec({"scenario": {"gait": "raibert", "duration": 1.0}, "grid": {"latency_steps": [1.5]}})


def test_authors_gait_on_the_spined_dog_is_their_run_with_the_seed_on_top():
    from sparc_quad.gaits import authors_run as A

    cfg = {"gait": "sine", "variant": "authors", "host": "spined-dog", "engine": "mujoco", "seed": 4,
           "step_length": 0.07, "kx": 500.0, "dx": 12.0, "duration": 6.0}
    bc = bound_config(cfg)
    ref = authors_config(step_length_m=0.07, k_x_n_m=500.0, duration_s=6.0)
    assert bc.spine_timing == ref.spine_timing == "authors" and bc.spine_params == ref.spine_params
    assert bc.world.imu == A.EXACT_IMU and bc.spine.k[0] == 500.0 and bc.spine.d[0] == 12.0
    p = perturbation(4)
    assert bc.world.mass_scale == p.mass_scale and bc.world.seed == 4 and bc.actuator_latency_steps == 0
    assert bc.gait.start_phase_rad == pytest.approx(2 * 3.141592653589793 * p.start_phase_cycles)
