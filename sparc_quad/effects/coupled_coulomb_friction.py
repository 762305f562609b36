"""Coulomb friction of a motor that turns with several joints: -u tau_c tanh(s' / eps)."""

from __future__ import annotations

from typing import ClassVar

import numpy as np

from sparc_quad.effects.base import Param
from sparc_quad.effects.coupled import DIRECTION, CoupledMotor
from sparc_quad.effects.registry import register


@register
class CoupledCoulombFriction(CoupledMotor):
    NAME = "coupled_coulomb_friction"
    DOC = "friction -u tau_c tanh(s'/eps)"
    PARAMS = (DIRECTION, Param("tau_c_nm", "N*m", "the motor's Coulomb level"))
    AMPLITUDE = "tau_c_nm"
    SYNTH_DEFAULTS: ClassVar[dict] = {"tau_c_nm": 0.15}

    @classmethod
    def friction(cls, state, law, torque, slope):
        for u, tc in state:  # slope: the diagonal of the coupled Jacobian
            ts = np.tanh((law.dq @ u) / law.eps)
            torque = torque - (tc * ts)[..., None] * u
            slope = slope + (tc * (1.0 - ts**2) / law.eps)[..., None] * u**2
        return torque, slope

    @classmethod
    def coordinate_column(cls, lib, b, u):
        sv, hs = b.dq_act_raw @ u, b.half_step_dq @ u
        ts = np.tanh(sv / lib.eps)
        return b.F(ts + (1.0 - ts**2) / lib.eps * hs)

    @classmethod
    def plausible(cls, p, sc, total_mass_kg):
        if not 0 < p["tau_c_nm"] < 0.5 * sc.tau_range:
            return "coupled Coulomb friction must be in (0, torque range / 2)"
        return None
