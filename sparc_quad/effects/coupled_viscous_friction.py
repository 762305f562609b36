"""Viscous friction of a motor that turns with several joints: -u b s'."""

from __future__ import annotations

from typing import ClassVar

from sparc_quad.effects.base import Param, positive_below, viscous_max
from sparc_quad.effects.coupled import DIRECTION, CoupledMotor
from sparc_quad.effects.registry import register


@register
class CoupledViscousFriction(CoupledMotor):
    NAME = "coupled_viscous_friction"
    DOC = "friction -u b s'"
    PARAMS = (DIRECTION, Param("b_nm_s_rad", "N*m*s/rad", "the motor's viscous coefficient along s"))
    AMPLITUDE = "b_nm_s_rad"
    SYNTH_DEFAULTS: ClassVar[dict] = {"b_nm_s_rad": 0.15}

    @classmethod
    def friction(cls, state, law, torque, slope):
        for u, b in state:
            torque = torque - (b * (law.dq @ u))[..., None] * u
            slope = slope + b * u**2
        return torque, slope

    @classmethod
    def coordinate_column(cls, lib, b, u):
        return b.dq_mid_f[:, lib.robot.act_idx] @ u

    @classmethod
    def plausible(cls, p, sc, total_mass_kg):
        return positive_below(p["b_nm_s_rad"], viscous_max(sc), "coupled viscous coefficient")
