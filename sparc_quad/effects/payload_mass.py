"""A point mass carried by one joint's child link (a payload, a cable, a sensor)."""

from __future__ import annotations

from typing import ClassVar

import numpy as np

from sparc_quad.effects.base import EffectKind, Param, Term, positive_below
from sparc_quad.effects.registry import register


@register
class PayloadMass(EffectKind):
    NAME = "payload_mass"
    DOC = "point mass on the joint's child link at xyz_m (link frame); the entry also names its link"
    PARAMS = (Param("mass_kg", "kg", "point mass"),
              Param("xyz_m", "m", "position on the joint's child link (its frame)", (0.0, 0.0, 0.0)))
    AMPLITUDE = "mass_kg"
    SYNTH_DEFAULTS: ClassVar[dict] = {"mass_kg": 0.1}
    ACTS_ON = "all"

    @classmethod
    def build(cls, entries, n):
        return [e for _j, _p, e in entries]

    @classmethod
    def apply_to_model(cls, state, model, joints):
        import pinocchio as pin

        for e in state:
            jid = model.getJointId(e.joint)
            xyz = np.asarray(e.params.get("xyz_m", [0.0, 0.0, 0.0]), dtype=float)
            point = pin.Inertia(float(e.params["mass_kg"]), xyz, np.zeros((3, 3)))
            model.inertias[jid] = model.inertias[jid] + point
        return model

    @classmethod
    def column(cls, lib, term, bi):
        b = lib.blocks[bi]
        return lib.robot.point_mass_column(lib.models[bi], term.joint, term.xyz, b.q_f(lib.nominal), b.dq_f,
                                           b.ddq_f)

    @classmethod
    def candidate(cls, sel, selected, joint):
        """At the link's centre of mass: the mass is what the data can tell apart from the link's own."""
        t = Term(cls.NAME, joint, link=sel.robot.child_link(joint), xyz=sel.robot.link_com(joint))
        return t, sel.fit([*selected, t])

    @classmethod
    def params(cls, t):
        return {"mass_kg": t.coef, "xyz_m": [float(x) for x in t.xyz]}, {"mass_kg": t.se}

    @classmethod
    def plausible(cls, p, sc, total_mass_kg):
        return positive_below(p["mass_kg"], max(2.0 * total_mass_kg, 1.0), "payload mass", "kg")

    @classmethod
    def synth_params(cls, given, robot, joint):
        params = {**cls.SYNTH_DEFAULTS, **given}
        params.setdefault("xyz_m", robot.link_com(joint).tolist())
        return params, robot.child_link(joint)
