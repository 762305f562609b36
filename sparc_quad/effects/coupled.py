"""What the coupled-motor effects share: one motor that turns with s = u . q over several joints (a wrist
whose motor 6 turns q5 + q6); each entry is listed with one joint and carries `direction` u (one number per
actuated joint). The search tries each alone and the three together, for every coupling the trials'
transmission declares (`sparc_quad.gap.select.couplings_from`)."""

from __future__ import annotations

import numpy as np

from sparc_quad.effects.base import EffectKind, Param, PlantEffectsError, Term
from sparc_quad.effects.registry import EFFECTS

DIRECTION = Param("direction", "1", "the motor's coordinate s = direction . q (one entry per actuated joint)")


class CoupledMotor(EffectKind):
    SINGLE = False
    ACTS_ON = "direction"

    @classmethod
    def build(cls, entries, n):
        """[(u, amplitude), ...]"""
        out = []
        for _j, p, _e in entries:
            u = np.asarray(p["direction"], dtype=float)
            if u.shape != (n,) or not np.all(np.isfinite(u)):
                raise PlantEffectsError(f"effect {cls.NAME}: direction needs {n} finite numbers")
            out.append((u, float(p[cls.AMPLITUDE])))
        return out

    @classmethod
    def column(cls, lib, term, bi):
        b = lib.blocks[bi]
        act = lib.robot.act_idx
        out = np.zeros((b.n, lib.robot.nv))
        out[:, act] = cls.coordinate_column(lib, b, term.direction)[:, None] * term.direction
        return out

    @classmethod
    def coordinate_column(cls, lib, b, u: np.ndarray) -> np.ndarray:
        raise NotImplementedError(cls.NAME)

    @classmethod
    def options(cls, search, selected, taken):
        """Every coupling: each coupled kind alone, then all of them together (once, by the first kind)."""
        family = [k for k in EFFECTS.values() if issubclass(k, CoupledMotor)]
        if cls is not family[0]:
            return []
        out = []
        for joint, u in search.couplings:
            rest = [Term(k.NAME, joint, direction=u) for k in family if (k.NAME, joint) not in taken]
            out += [[t] for t in rest]
            if len(rest) >= 2:
                out.append(rest)
        return out

    @classmethod
    def params(cls, t):
        return {"direction": [float(x) for x in t.direction], cls.AMPLITUDE: t.coef}, {cls.AMPLITUDE: t.se}

    @classmethod
    def synth_params(cls, given, robot, joint):
        if "direction" not in given:
            raise ValueError(f"{cls.NAME} needs direction=u1;u2;... (one entry per actuated joint)")
        return {**cls.SYNTH_DEFAULTS, **given}, None
