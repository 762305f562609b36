"""Viscous friction on one joint."""

from __future__ import annotations

from typing import ClassVar

from sparc_quad.effects.base import EffectKind, Param, positive_below, viscous_max
from sparc_quad.effects.registry import register


@register
class ViscousFriction(EffectKind):
    NAME = "viscous_friction"
    DOC = "friction -b dq"
    PARAMS = (Param("b_nm_s_rad", "N*m*s/rad", "viscous coefficient"),)
    AMPLITUDE = "b_nm_s_rad"
    SYNTH_DEFAULTS: ClassVar[dict] = {"b_nm_s_rad": 0.15}
    EXPECTED = True

    @classmethod
    def friction_law(cls, state, law):
        law.linear = law.linear + state

    @classmethod
    def signal(cls, lib, term, bi, ja):
        return lib.blocks[bi].dq_mid_f[:, lib.joint_v(term.joint)]

    @classmethod
    def plausible(cls, p, sc, total_mass_kg):
        return positive_below(p["b_nm_s_rad"], viscous_max(sc), "viscous coefficient", "N*m*s/rad")
