"""A torque constant off by a factor: applied = gain * commanded."""

from __future__ import annotations

from typing import ClassVar

import numpy as np

from sparc_quad.effects.base import EffectKind, Param
from sparc_quad.effects.registry import register


@register
class TorqueGain(EffectKind):
    NAME = "torque_gain"
    DOC = "applied = gain * commanded"
    PARAMS = (Param("gain", "1", "applied / commanded torque"),)
    AMPLITUDE = "gain"
    SYNTH_DEFAULTS: ClassVar[dict] = {"gain": 0.85}
    STAGE = 2

    @classmethod
    def build(cls, entries, n):
        out = np.ones(n)
        for j, p, _e in entries:
            out[j] *= p["gain"]
        return out

    @classmethod
    def actuate(cls, state, tau):
        return state * tau

    @classmethod
    def signal(cls, lib, term, bi, ja):
        return -lib.blocks[bi].F(lib.applied(bi, ja))  # r = (1 - k) tau = -(k - 1) tau: amplitude k - 1

    @classmethod
    def params(cls, t):
        return {"gain": 1.0 + t.coef}, {"gain": t.se}

    @classmethod
    def plausible(cls, p, sc, total_mass_kg):
        return None if 0.3 < p["gain"] < 1.5 else "torque gain must be in (0.3, 1.5)"
