"""A direction-dependent Coulomb level on one joint (refines a Coulomb friction)."""

from __future__ import annotations

from typing import ClassVar

import numpy as np

from sparc_quad.effects.base import EffectKind, Param, Term, smoothed_sign
from sparc_quad.effects.registry import register


@register
class AsymmetricCoulomb(EffectKind):
    NAME = "asymmetric_coulomb"
    DOC = ("friction -delta |tanh(dq/eps)|: the Coulomb level is tau_c + delta moving +, tau_c - delta "
           "moving -")
    PARAMS = (Param("delta_nm", "N*m", "half the difference of the two Coulomb levels"),)
    AMPLITUDE = "delta_nm"
    SYNTH_DEFAULTS: ClassVar[dict] = {"delta_nm": 0.06}
    SINGLE = False
    REFINES = "coulomb_friction"

    @classmethod
    def friction_law(cls, state, law):
        law.even = law.even + state

    @classmethod
    def signal(cls, lib, term, bi, ja):
        b = lib.blocks[bi]
        _dq, th, dth, half = smoothed_sign(b, ja, lib.eps)
        return b.F(np.abs(th) + np.sign(th) * dth * half)

    @classmethod
    def joint_options(cls, search, selected, taken, joint) -> list:
        """A direction-dependent Coulomb level refines a Coulomb friction already in the model (named, or
        in the nominal plant)."""
        has = (cls.REFINES, joint) in taken or (cls.REFINES, joint) in getattr(search, "in_nominal", ())
        if has and (cls.NAME, joint) not in taken:
            return [[Term(cls.NAME, joint)]]
        return []

    @classmethod
    def plausible(cls, p, sc, total_mass_kg):
        if not abs(p["delta_nm"]) < 0.5 * sc.tau_range:
            return "Coulomb asymmetry beyond half the torque range"
        return None
