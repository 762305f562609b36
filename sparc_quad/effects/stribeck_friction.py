"""Stribeck friction on one joint: the breakaway excess above Coulomb, fading with speed."""

from __future__ import annotations

from typing import ClassVar

import numpy as np

from sparc_quad.effects.base import EffectKind, Param, smoothed_sign
from sparc_quad.effects.registry import register


@register
class StribeckFriction(EffectKind):
    NAME = "stribeck_friction"
    DOC = "friction -tau_s exp(-(|dq|/dq_s)^2) tanh(dq/eps): the breakaway excess above Coulomb"
    PARAMS = (Param("tau_s_nm", "N*m", "breakaway excess"), Param("dq_s_rad_s", "rad/s", "Stribeck velocity"))
    AMPLITUDE = "tau_s_nm"
    SYNTH_DEFAULTS: ClassVar[dict] = {"tau_s_nm": 0.25, "dq_s_rad_s": 0.3}

    @classmethod
    def build(cls, entries, n):
        """(joint index, amplitude, velocity) per entry, and the (n, entries) indicator that sums them."""
        j = np.array([e[0] for e in entries], dtype=int)
        tau = np.array([float(e[1]["tau_s_nm"]) for e in entries])
        dqs = np.array([float(e[1]["dq_s_rad_s"]) for e in entries])
        total = np.zeros((n, len(entries)))
        total[j, np.arange(len(entries))] = 1.0
        return j, tau, dqs, total

    @classmethod
    def friction_law(cls, state, law):
        j, tau, dqs, total = state
        x = law.dq[..., j] / dqs
        e = tau * np.exp(-(x**2))
        law.level = law.level + e @ total.T
        law.dlevel = law.dlevel + (e * (-2.0 * x / dqs)) @ total.T

    @classmethod
    def signal(cls, lib, term, bi, ja):
        b = lib.blocks[bi]
        dq, th, dth, half = smoothed_sign(b, ja, lib.eps)
        x = dq / term.theta
        e = np.exp(-(x**2))
        return b.F(e * th + (e * dth - 2.0 * x / term.theta * e * th) * half)

    @classmethod
    def grid(cls, sel, joint):
        ja = sel.robot.actuated.index(joint)
        dq = np.concatenate([np.abs(sel.lib.blocks[b].dq_act_raw[:, ja]) for b in sel.train])
        hi = max(float(np.percentile(dq, 90)), 0.02)
        return list(np.geomspace(0.01, hi, 14))

    @classmethod
    def params(cls, t):
        return {"tau_s_nm": t.coef, "dq_s_rad_s": t.theta}, {"tau_s_nm": t.se, "dq_s_rad_s": t.theta_se}

    @classmethod
    def plausible(cls, p, sc, total_mass_kg):
        if not (0 < p["tau_s_nm"] < 0.5 * sc.tau_range
                and 1e-3 <= p["dq_s_rad_s"] <= 5 * max(sc.dq_rms, 1.0)):
            return "Stribeck excess must be positive, its velocity within the data's range"
        return None
