"""The rotor inertia of a motor that turns with several joints: M += I u u^T."""

from __future__ import annotations

from typing import ClassVar

import numpy as np

from sparc_quad.effects.base import Param, inertia_max, positive_below
from sparc_quad.effects.coupled import DIRECTION, CoupledMotor
from sparc_quad.effects.registry import register
from spine_module import params as P


@register
class CoupledRotorInertia(CoupledMotor):
    NAME = "coupled_rotor_inertia"
    DOC = "M += I u u^T"
    PARAMS = (DIRECTION, Param("inertia_kg_m2", "kg*m^2", "the motor's rotor inertia along s"))
    AMPLITUDE = "inertia_kg_m2"
    SYNTH_DEFAULTS: ClassVar[dict] = {"inertia_kg_m2": 2.0 * P.REFLECTED_ROTOR_INERTIA_KG_M2}

    @classmethod
    def coupled_mass(cls, state):
        out = 0.0
        for u, inertia in state:
            out = out + inertia * np.outer(u, u)
        return out

    @classmethod
    def coordinate_column(cls, lib, b, u):
        return b.ddq_f[:, lib.robot.act_idx] @ u

    @classmethod
    def plausible(cls, p, sc, total_mass_kg):
        return positive_below(p["inertia_kg_m2"], inertia_max(sc), "coupled rotor inertia", "kg*m^2")
