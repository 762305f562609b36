"""Coulomb friction on one joint (eq. 4's constant level)."""

from __future__ import annotations

from typing import ClassVar

from sparc_quad.effects.base import EffectKind, Param, positive_below, smoothed_sign
from sparc_quad.effects.registry import register


@register
class CoulombFriction(EffectKind):
    NAME = "coulomb_friction"
    DOC = "friction -tau_c tanh(dq / eps)"
    PARAMS = (Param("tau_c_nm", "N*m", "Coulomb level"),)
    AMPLITUDE = "tau_c_nm"
    SYNTH_DEFAULTS: ClassVar[dict] = {"tau_c_nm": 0.15}
    EXPECTED = True

    @classmethod
    def friction_law(cls, state, law):
        law.level = law.level + state

    @classmethod
    def signal(cls, lib, term, bi, ja):
        b = lib.blocks[bi]
        _dq, th, dth, half = smoothed_sign(b, ja, lib.eps)
        return b.F(th + dth * half)

    @classmethod
    def plausible(cls, p, sc, total_mass_kg):
        return positive_below(p["tau_c_nm"], 0.5 * sc.tau_range, "Coulomb friction", "N*m")
