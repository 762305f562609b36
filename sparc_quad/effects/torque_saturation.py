"""A torque limit below the commanded range: applied clipped to +-limit."""

from __future__ import annotations

from typing import ClassVar

import numpy as np

from sparc_quad.effects.base import EffectKind, Param
from sparc_quad.effects.command import abs_command
from sparc_quad.effects.registry import register

# A limit must be exceeded by the command on this share of the samples at least (else the "limit" fits a few
# outliers). No upper bound: under feedback the controller winds up against the limit, so the command
# exceeds it on most samples or all (gap synth, the spine's q2 limited to half its peak demand: 93-100 %);
# an actuator whose applied torque is +-limit throughout is still a limit, and no other effect has that
# residual (commanded - limit sign(commanded)).
SATURATED_FRACTION_MIN = 0.005
GRID_SPAN = 16  # the grid also holds peak * k / GRID_SPAN, k = 1..GRID_SPAN-1


@register
class TorqueSaturation(EffectKind):
    NAME = "torque_saturation"
    DOC = "applied clipped to +-limit"
    PARAMS = (Param("limit_nm", "N*m", "torque limit"),)
    SYNTH_DEFAULTS: ClassVar[dict] = {"limit_fraction": 0.8}  # of the joint's peak |tau_cmd| in a nominal run
    SYNTH_ONLY = ("limit_fraction",)
    STAGE = 4
    FIXED = True
    ON_COMMAND = True

    @classmethod
    def build(cls, entries, n):
        out = np.full(n, np.inf)
        for j, p, _e in entries:
            out[j] = min(out[j], p["limit_nm"])
        return out

    @classmethod
    def actuate(cls, state, tau):
        return np.clip(tau, -state, state)

    @classmethod
    def signal(cls, lib, term, bi, ja):
        tau = lib.applied(bi, ja)
        return lib.blocks[bi].F(tau - np.clip(tau, -term.theta, term.theta))

    @classmethod
    def grid(cls, sel, joint):
        """Percentiles of |command| (dense where the samples are) and an even span of (0, peak): a command
        wound up against a low limit has no percentile near it (the limit lies below them all)."""
        cmd = abs_command(sel, joint)
        pct = [*range(2, 90, 4), 90, 92, 94, 96, 97, 98, 99, 99.5, 99.8, 99.9, 99.95]
        span = cmd.max() * np.arange(1, GRID_SPAN) / GRID_SPAN
        return list(np.unique(np.concatenate([np.percentile(cmd, pct), span])))

    @classmethod
    def params(cls, t):
        return {"limit_nm": t.theta}, {"limit_nm": t.theta_se}

    @classmethod
    def plausible(cls, p, sc, total_mass_kg):
        if not 0 < p["limit_nm"] < sc.tau_peak:
            return "limit must lie below the peak command"
        frac = float(np.mean(sc.abs_tau > p["limit_nm"]))
        if frac < SATURATED_FRACTION_MIN:
            return (f"commanded torque exceeds the limit on {100 * frac:.2f} % of the samples (a clipped "
                    f"signature needs {100 * SATURATED_FRACTION_MIN:.1f} % at least)")
        return None

    @classmethod
    def resolve_synth(cls, params, joint_index, nominal_peak_nm):
        if "limit_fraction" in params:
            frac = params.pop("limit_fraction")
            params.setdefault("limit_nm", float(frac * nominal_peak_nm(joint_index)))
