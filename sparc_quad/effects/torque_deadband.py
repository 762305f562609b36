"""A deadband around zero command: applied = sign(c) max(|c| - width, 0)."""

from __future__ import annotations

from typing import ClassVar

import numpy as np

from sparc_quad.effects.base import EffectKind, Param
from sparc_quad.effects.command import abs_command
from sparc_quad.effects.registry import register


@register
class TorqueDeadband(EffectKind):
    NAME = "torque_deadband"
    DOC = "applied = sign(c) max(|c| - width, 0)"
    PARAMS = (Param("width_nm", "N*m", "deadband half-width"),)
    SYNTH_DEFAULTS: ClassVar[dict] = {"width_nm": 0.1}
    STAGE = 1
    FIXED = True
    ON_COMMAND = True

    @classmethod
    def actuate(cls, state, tau):
        return np.sign(tau) * np.maximum(np.abs(tau) - state, 0.0)

    @classmethod
    def signal(cls, lib, term, bi, ja):
        tau = lib.applied(bi, ja)
        return lib.blocks[bi].F(np.sign(tau) * np.minimum(np.abs(tau), term.theta))

    @classmethod
    def grid(cls, sel, joint):
        top = float(np.percentile(abs_command(sel, joint), 50))
        return list(np.linspace(top / 25, top, 25))

    @classmethod
    def params(cls, t):
        return {"width_nm": t.theta}, {"width_nm": t.theta_se}

    @classmethod
    def plausible(cls, p, sc, total_mass_kg):
        return None if 0 < p["width_nm"] < 0.5 * sc.tau_peak else "deadband must be below half the peak"
