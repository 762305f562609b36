"""The effect library: what a real actuator and its load add to a rigid-body URDF model, one module per
effect kind (its parameters, forward model, regressor column, search grid, plausibility bounds, synthetic
defaults and report format), kept by name in `EFFECTS` as python-can keeps its interfaces behind BACKENDS.

The plant file that carries them (`plant.py`, schema sparc-quad/plant-effects/1) is read by every
simulation that takes `--plant FILE` and written by the gap workflow. Adding an effect: a new module here
with one `@register`ed `EffectKind` subclass (see docs/gap.md, "Effect library").
"""

from __future__ import annotations

import importlib
import pkgutil

from sparc_quad.effects.base import Effect, EffectKind, Param, PlantEffectsError, Term, format_value
from sparc_quad.effects.plant import SCHEMA, PlantEffects
from sparc_quad.effects.registry import EFFECTS, UnknownEffect, kind, names, register, unregister

# The shipped kinds in the order the plant sums them and the search tries them (the order the gap results
# were validated in); any other module of this package registers after them, in name order.
BUILTIN = ("coulomb_friction", "viscous_friction", "stribeck_friction", "rotor_inertia", "torque_gain",
           "torque_offset", "time_delay", "link_inertia", "payload_mass", "encoder_offset",
           "torque_saturation", "torque_deadband", "asymmetric_coulomb", "coupled_rotor_inertia",
           "coupled_coulomb_friction", "coupled_viscous_friction")
_HELPERS = ("base", "registry", "plant", "command", "coupled")

for _name in (*BUILTIN, *sorted(m.name for m in pkgutil.iter_modules(__path__)
                                if m.name not in BUILTIN and m.name not in _HELPERS)):
    importlib.import_module(f"{__name__}.{_name}")

def markdown_table() -> str:
    """The kinds as docs/gap.md lists them (a test keeps the two equal): name, parameters with units, what
    the kind does, its role in the search."""
    rows = ["| effect | parameters (SI) | what it does | search | `gap synth` default |",
            "|---|---|---|---|---|"]
    for name, k in EFFECTS.items():
        ps = ", ".join(f"`{p.key}` ({p.unit}{', optional' if p.default is not None else ''})"
                       for p in k.PARAMS)
        roles = ["alone on every joint"] if k.SINGLE else []
        roles += ["in the expected group"] if k.EXPECTED else []
        roles += [f"next to `{k.REFINES}`"] if k.REFINES else []
        roles += ["its own options"] if k.options.__func__ is not EffectKind.options.__func__ else []
        roles += ["not on measured torque"] if k.ON_COMMAND else []
        role = "; ".join(roles)
        synth = ", ".join(f"{key}={format_value(v)}" for key, v in k.SYNTH_DEFAULTS.items())
        synth = synth or (k.synth_params.__doc__ or "").strip() or "none"
        rows.append(f"| `{name}` | {ps} | {k.DOC.replace('|', chr(92) + '|')} | {role} | {synth} |")
    return "\n".join(rows) + "\n"


__all__ = ["EFFECTS", "SCHEMA", "Effect", "EffectKind", "Param", "PlantEffects", "PlantEffectsError", "Term",
           "UnknownEffect", "kind", "markdown_table", "names", "register", "unregister"]
