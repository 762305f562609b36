"""Base parameters of the link inertial-parameter effect: the pivoted QR's combinations reproduce every
dependent regressor column, and the plant file applies a link correction (refusing a non-positive mass)."""

from __future__ import annotations

import numpy as np
import pytest

from sparc_quad.effects import Effect, PlantEffects, PlantEffectsError
from sparc_quad.gap.base_params import BaseParameters, regressor
from sparc_quad.gap.robot import Robot
from tests.paths import DATA

URDF = DATA / "staubli_tx40" / "tx40_mdh_modified.urdf"
JOINTS = [f"joint_{i}" for i in range(1, 7)]


def test_combinations_reproduce_the_regressor():
    rb = Robot(URDF, JOINTS, {}, (0, 0, -9.81))
    rng = np.random.default_rng(0)
    q, dq, ddq = rng.uniform(-1, 1, (200, 6)), rng.normal(size=(200, 6)), rng.normal(size=(200, 6))
    W = regressor(rb.model, q, dq, ddq).reshape(-1, 60)
    bp = BaseParameters(rb.model, W)
    assert 20 <= len(bp.independent) < 60
    np.testing.assert_allclose(W[:, bp.dependent], W[:, bp.independent] @ bp.B, atol=1e-9)
    # every column is independent, dependent, or never excited (zero)
    rest = set(range(60)) - set(bp.independent) - set(bp.dependent)
    assert all(np.allclose(W[:, c], 0.0) for c in rest)
    assert bp.columns_of(1) and all(bp.body_of(c) == 1 for c in bp.columns_of(1))
    assert any(" " in bp.combination(c) for c in bp.independent)  # some are combinations
    # new samples obey the same combinations: structural, not an accident of these samples
    W2 = regressor(rb.model, rng.uniform(-1, 1, (50, 6)), rng.normal(size=(50, 6)),
                   rng.normal(size=(50, 6))).reshape(-1, 60)
    np.testing.assert_allclose(W2[:, bp.dependent], W2[:, bp.independent] @ bp.B, atol=1e-9)


def test_plant_applies_link_correction():
    rb = Robot(URDF, JOINTS, {}, (0, 0, -9.81))
    m0 = rb.model.inertias[2].mass
    pe = PlantEffects(JOINTS, [Effect("link_inertia", "joint_2", {"param_index": 0, "delta": 0.5})])
    assert pe.apply_to_pinocchio(rb.model).inertias[2].mass == pytest.approx(m0 + 0.5)
    bad = PlantEffects(JOINTS, [Effect("link_inertia", "joint_2", {"param_index": 0, "delta": -m0 - 1})])
    with pytest.raises(PlantEffectsError, match="not positive"):
        bad.apply_to_pinocchio(rb.model)
