"""Motor-bus backends by name, for `spine-node --motors NAME`, built from keyword arguments.

Each entry is a module path, imported only when chosen, so a backend's dependencies are not needed by
the others. The module provides

    def make_bus(*, lc: lcm.LCM | None = None, **options) -> MotorBus

with its options as keyword arguments (as `can.Bus(interface=..., channel=...)` takes them): a program,
a test or a config file builds a bus the same way the command line does. `lc` is the node's LCM instance
(the LCM backend shares it so all channels dispatch in order); other backends ignore it. Add a backend by
adding a line here (or calling `register`).
"""

from __future__ import annotations

import importlib
import inspect
from types import ModuleType

from spine_module.buses.base import MotorBus

BACKENDS: dict[str, str] = {
    "lcm": "spine_module.buses.lcm_backend",
    "inprocess": "spine_module.buses.inprocess_backend",
    "can": "spine_module.buses.cybergear.backend",  # CyberGear motors on CAN
}


def register(name: str, module: str) -> None:
    BACKENDS[name] = module


def backend_module(name: str) -> ModuleType:
    try:
        path = BACKENDS[name]
    except KeyError:
        raise ValueError(f"unknown motor backend {name!r}; known: {', '.join(sorted(BACKENDS))}") from None
    try:
        return importlib.import_module(path)
    except Exception as exc:
        raise ValueError(f"motor backend {name!r} ({path}) is not available: {exc!r}") from exc


def make_bus(name: str, *, lc=None, **options: object) -> MotorBus:
    """The backend `name`'s bus, built from keyword `options` (unknown options are an error naming them)."""
    mod = backend_module(name)
    factory = getattr(mod, "make_bus", None)
    if factory is None:
        raise ValueError(f"motor backend {name!r} has no make_bus(*, lc, **options)")
    known = inspect.signature(factory).parameters
    if not any(p.kind is inspect.Parameter.VAR_KEYWORD for p in known.values()):
        unknown = sorted(set(options) - set(known))
        if unknown:
            raise ValueError(f"motor backend {name!r} takes no option(s) {', '.join(unknown)}; "
                             f"it takes: {', '.join(k for k in known if k != 'lc') or 'none'}")
    return factory(lc=lc, **options)
