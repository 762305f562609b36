"""Residual columns of candidate effects on the blocks: each effect kind computes its own
(`EffectKind.column`); this library holds what they share (blocks, the nominal plant and model, the
rigid-body regressor and its base parameters) and caches the columns.

A column is linear in the effect's amplitude, or a fixed column (a nonlinear map of the commanded torque
at a given shape parameter), computed at full rate, filtered by the blocks' low-pass and decimated.
"""

from __future__ import annotations

import numpy as np

from sparc_quad.effects import Term
from sparc_quad.effects.plant import PlantEffects
from sparc_quad.gap.base_params import BaseParameters, regressor
from sparc_quad.gap.filtering import Block

CACHE_MAX = 4000  # columns kept before the cache is cleared


class Library:
    """Computes columns for every effect on the blocks, with caching."""

    def __init__(self, blocks: list[Block], nominal: PlantEffects):
        self.blocks = blocks
        self.nominal = nominal
        self.robot = blocks[0].robot
        self.eps = nominal.eps
        self._cache: dict = {}
        self.models = [self.robot.plant_model(nominal)] * len(blocks)
        self._regressors: dict[int, np.ndarray] = {}
        self._applied: dict[int, np.ndarray] = {}
        self._base: BaseParameters | None = None

    def regressor(self, bi: int) -> np.ndarray:
        """(n_dec, nv, 10 nbodies) joint-torque regressor of block bi (nominal model, filtered signals)."""
        if bi not in self._regressors:
            b = self.blocks[bi]
            self._regressors[bi] = regressor(self.models[bi], b.q_f(self.nominal), b.dq_f, b.ddq_f)
        return self._regressors[bi]

    def base_parameters(self, train: list[int]) -> BaseParameters:
        if self._base is None:
            W = np.vstack([self.regressor(bi).reshape(-1, self.regressor(bi).shape[2]) for bi in train])
            self._base = BaseParameters(self.models[0], W)
        return self._base

    def applied(self, bi: int, ja: int) -> np.ndarray:
        """The nominal plant's applied torque of block bi on actuated joint ja, full rate (N*m)."""
        if bi not in self._applied:
            b = self.blocks[bi]
            self._applied[bi] = self.nominal.applied_torque_series(b.trial.tau_cmd, b.trial.dt)
        return self._applied[bi][:, ja]

    def joint_v(self, joint: str) -> int:
        return int(self.robot.act_idx[self.robot.actuated.index(joint)])

    def column(self, term: Term, bi: int) -> np.ndarray:
        """(n_dec, nv) column for block bi (linear amplitude 1, or the fixed map)."""
        key = (term.name, term.joint, term.theta, term.param_index, bi)
        if key in self._cache:
            return self._cache[key]
        col = term.kind.column(self, term, bi)
        if len(self._cache) > CACHE_MAX:
            self._cache.clear()
        self._cache[key] = col
        return col
