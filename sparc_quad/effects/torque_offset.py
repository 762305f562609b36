"""A constant torque offset: applied = commanded + offset."""

from __future__ import annotations

from typing import ClassVar

import numpy as np

from sparc_quad.effects.base import EffectKind, Param
from sparc_quad.effects.registry import register


@register
class TorqueOffset(EffectKind):
    NAME = "torque_offset"
    DOC = "applied = commanded + offset"
    PARAMS = (Param("offset_nm", "N*m", "added torque"),)
    AMPLITUDE = "offset_nm"
    SYNTH_DEFAULTS: ClassVar[dict] = {"offset_nm": 0.1}
    STAGE = 3

    @classmethod
    def actuate(cls, state, tau):
        return tau + state

    @classmethod
    def signal(cls, lib, term, bi, ja):
        return -np.ones(lib.blocks[bi].n)

    @classmethod
    def plausible(cls, p, sc, total_mass_kg):
        if not abs(p["offset_nm"]) < 0.25 * sc.tau_range:
            return "offset beyond a quarter of the torque range"
        return None
