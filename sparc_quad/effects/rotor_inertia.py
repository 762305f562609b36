"""Reflected rotor inertia of one joint's motor (pinocchio's armature)."""

from __future__ import annotations

from typing import ClassVar

from sparc_quad.effects.base import EffectKind, Param, inertia_max, positive_below
from sparc_quad.effects.registry import register
from spine_module import params as P


@register
class RotorInertia(EffectKind):
    NAME = "rotor_inertia"
    DOC = "reflected rotor inertia added to M (armature)"
    PARAMS = (Param("inertia_kg_m2", "kg*m^2", "reflected rotor inertia"),)
    AMPLITUDE = "inertia_kg_m2"
    SYNTH_DEFAULTS: ClassVar[dict] = {"inertia_kg_m2": 2.0 * P.REFLECTED_ROTOR_INERTIA_KG_M2}
    EXPECTED = True

    @classmethod
    def armature_kg_m2(cls, state):
        return state

    @classmethod
    def signal(cls, lib, term, bi, ja):
        return lib.blocks[bi].ddq_f[:, lib.joint_v(term.joint)]

    @classmethod
    def plausible(cls, p, sc, total_mass_kg):
        return positive_below(p["inertia_kg_m2"], inertia_max(sc), "rotor inertia", "kg*m^2")
