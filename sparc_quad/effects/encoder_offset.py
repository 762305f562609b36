"""An encoder zero off by a constant: measured q = true q + offset."""

from __future__ import annotations

from typing import ClassVar

import numpy as np

from sparc_quad.effects.base import EffectKind, Param, Term
from sparc_quad.effects.registry import register


@register
class EncoderOffset(EffectKind):
    NAME = "encoder_offset"
    DOC = "measured q = true q + offset"
    PARAMS = (Param("offset_rad", "rad", "encoder zero error"),)
    AMPLITUDE = "offset_rad"
    SYNTH_DEFAULTS: ClassVar[dict] = {"offset_rad": 0.05}
    ACTS_ON = "all"

    @classmethod
    def encoder_offset_rad(cls, state):
        return state

    @classmethod
    def n_params(cls, term):
        return 1  # theta is the linearisation point, tied to the amplitude

    @classmethod
    def column(cls, lib, term, bi):
        """d residual / d offset: the tangent at 0, or the secant through the estimate theta (exact there)."""
        b = lib.blocks[bi]
        v = lib.joint_v(term.joint)
        q = b.q_f(lib.nominal)
        m = lib.models[bi]
        rb = lib.robot
        if term.theta:
            qs = q.copy()
            qs[:, v] -= term.theta
            return (rb.rnea(m, qs, b.dq_f, b.ddq_f) - rb.rnea(m, q, b.dq_f, b.ddq_f)) / term.theta
        return -rb.rnea_dq(m, q, b.dq_f, b.ddq_f)[:, :, v]

    @classmethod
    def candidate(cls, sel, selected, joint):
        """Gauss-Newton: the tangent, then secants through the estimate."""
        t = Term(cls.NAME, joint)
        fit = sel.fit([*selected, t])
        for _ in range(2):
            delta = float(fit.beta[sum(not x.fixed for x in fit.terms) - 1])
            if not (np.isfinite(delta) and 1e-6 < abs(delta) < 0.5):
                break
            t = Term(cls.NAME, joint, theta=delta)
            fit = sel.fit([*selected, t])
        return t, fit

    @classmethod
    def plausible(cls, p, sc, total_mass_kg):
        return None if abs(p["offset_rad"]) < 0.5 else "encoder offset beyond 0.5 rad"
