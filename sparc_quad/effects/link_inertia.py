"""An error in one standard dynamic parameter of a joint's body (its URDF mass, first or second moment).

The data identify base parameters only (`sparc_quad.gap.base_params`): the term stands for the combination
its independent column identifies, which the report names (`combination`)."""

from __future__ import annotations

import numpy as np

from sparc_quad.effects.base import EffectKind, Param, PlantEffectsError, Term
from sparc_quad.effects.registry import register

PARAM_ORDER = "m, mx, my, mz, Ixx, Ixy, Iyy, Ixz, Iyz, Izz (pinocchio's order, about the joint frame)"


@register
class LinkInertia(EffectKind):
    NAME = "link_inertia"
    DOC = "error `delta` in standard dynamic parameter `param_index` of the joint's body"
    PARAMS = (Param("param_index", "1", f"0-9: {PARAM_ORDER}"),
              Param("delta", "kg, kg*m or kg*m^2", "error of that parameter (SI)"))
    AMPLITUDE = "delta"
    SINGLE = False
    ACTS_ON = "all"

    @classmethod
    def build(cls, entries, n):
        deltas: dict[str, np.ndarray] = {}
        for _j, p, e in entries:
            deltas.setdefault(e.joint, np.zeros(10))[int(p["param_index"])] += float(p["delta"])
        return deltas

    @classmethod
    def apply_to_model(cls, state, model, joints):
        import pinocchio as pin

        for joint, dpi in state.items():
            jid = model.getJointId(joint)
            pi = model.inertias[jid].toDynamicParameters() + dpi
            if not pi[0] > 0:
                raise PlantEffectsError(f"link_inertia on {model.names[jid]!r}: mass {pi[0]:.4g} kg is not "
                                        "positive")
            model.inertias[jid] = pin.Inertia.FromDynamicParameters(pi)
        return model

    @classmethod
    def key(cls, term):
        return (cls.NAME, term.joint, term.param_index)

    @classmethod
    def column(cls, lib, term, bi):
        return lib.regressor(bi)[:, :, term.param_index]

    @classmethod
    def options(cls, search, selected, taken):
        """Per joint, its body's base parameters not yet in the model; of those, the ones > 2 standard
        errors when fitted together (all if none is)."""
        sel, rb = search.sel, search.rb
        out = []
        for joint in rb.actuated:
            base = sel.lib.base_parameters(sel.train)
            jid = rb.model.getJointId(joint)
            link = [Term(cls.NAME, joint, param_index=c, combination=base.combination(c),
                         link=rb.child_link(joint)) for c in base.columns_of(jid)]
            link = [t for t in link if t.key not in taken]
            if link:
                search.assign([*selected, *link])
                keep = [t for t in link if np.isfinite(t.se) and abs(t.coef) > 2 * t.se]
                out.append(keep or link)
        return out

    @classmethod
    def params(cls, t):
        return ({"param_index": t.param_index % 10, "delta": t.coef, "combination": t.combination},
                {"delta": t.se})

    @classmethod
    def plausible(cls, p, sc, total_mass_kg):
        return None if np.isfinite(p["delta"]) else "not finite"

    @classmethod
    def model_problem(cls, search, fit):
        """The corrected bodies must still have a positive mass."""
        links = [t.effect() for t in fit.terms if t.name == cls.NAME]
        if links:
            try:
                search.sel.lib.nominal.with_effects(links).apply_to_pinocchio(search.rb.model)
            except PlantEffectsError as exc:
                return str(exc)
        return None

    @classmethod
    def synth_params(cls, given, robot, joint):
        """Default: the body's mass 10 % heavier than its URDF says."""
        params = {"param_index": 0, "delta": 0.1 * robot.link_mass(joint), **given}
        params["param_index"] = int(params["param_index"])
        return params, robot.child_link(joint)
