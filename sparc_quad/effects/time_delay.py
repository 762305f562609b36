"""A transport delay between command and torque: applied(t) = commanded(t - delay)."""

from __future__ import annotations

import math
from typing import ClassVar

import numpy as np

from sparc_quad.effects.base import EffectKind, Param, Term
from sparc_quad.effects.registry import register

MAX_DELAY_S = 0.05


@register
class TimeDelay(EffectKind):
    NAME = "time_delay"
    DOC = "applied(t) = commanded(t - delay)"
    PARAMS = (Param("delay_s", "s", "delay, rounded to whole control periods"),)
    SYNTH_DEFAULTS: ClassVar[dict] = {"delay_s": 0.008}
    FIXED = True
    ON_COMMAND = True

    @classmethod
    def delay_s(cls, state):
        return state

    @classmethod
    def signal(cls, lib, term, bi, ja):
        b = lib.blocks[bi]
        tau = lib.applied(bi, ja)
        s = round(term.theta / b.trial.dt)
        shifted = np.concatenate([np.full(s, tau[0]), tau[:-s]]) if s > 0 else tau
        return b.F(tau - shifted)

    @classmethod
    def candidate(cls, sel, selected, joint):
        """Integer delays in samples (`delay_search`); the standard error from the BIC's curvature."""
        dt = sel.lib.blocks[0].trial.dt
        s_max = max(1, round(MAX_DELAY_S / dt))
        s = delay_search(lambda k: sel.fit([*selected, Term(cls.NAME, joint, theta=k * dt)]).bic, s_max)
        best = sel.fit([*selected, Term(cls.NAME, joint, theta=s * dt)])
        t = best.terms[-1]
        fm = sel.fit([*selected, Term(cls.NAME, joint, theta=(s - 1) * dt)]).bic
        fp = sel.fit([*selected, Term(cls.NAME, joint, theta=(s + 1) * dt)]).bic
        curv = (fp - 2 * best.bic + fm) / dt**2
        t.theta_se = math.sqrt(2.0 / curv) if curv > 0 else float("inf")
        return t, best

    @classmethod
    def params(cls, t):
        return {"delay_s": t.theta}, {"delay_s": t.theta_se}

    @classmethod
    def plausible(cls, p, sc, total_mass_kg):
        return None if 0 < p["delay_s"] <= MAX_DELAY_S else "delay must be in (0, 50 ms]"


def delay_search(bic_of, s_max: int) -> int:
    """Integer delay (samples) in 1..s_max minimising bic_of: a geometric coarse grid, then brackets
    around the best point narrowed until every sample in the bracket has been tried (coarse to fine)."""
    seen: dict[int, float] = {}

    def f(s: int) -> float:
        if s not in seen:
            seen[s] = bic_of(s)
        return seen[s]

    pts = sorted({int(x) for x in np.unique(np.round(np.geomspace(1, s_max, 10)))})
    while True:
        vals = [f(p) for p in pts]
        i = int(np.argmin(vals))
        lo, hi = pts[max(i - 1, 0)], pts[min(i + 1, len(pts) - 1)]
        if hi - lo <= 8:
            for p in range(lo, hi + 1):
                f(p)
            return min(seen, key=seen.get)
        pts = sorted({int(x) for x in np.round(np.linspace(lo, hi, 7))})
