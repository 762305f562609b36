"""Motor-bus backends by name, for `spine-node --motors NAME`.

Each entry is a module path, imported only when chosen, so a backend's dependencies are not
needed by the others. The module provides:

    def make_bus(args: argparse.Namespace, lc: lcm.LCM | None) -> MotorBus   # the factory
    def add_arguments(parser: argparse.ArgumentParser) -> None              # optional CLI options

`lc` is the node's LCM instance (the LCM backend shares it so all channels dispatch in order); other
backends may ignore it. Add a backend by adding a line here (or calling `register`).
"""

from __future__ import annotations

import argparse
import importlib
from collections.abc import Callable

from spine_module.buses.base import MotorBus

BACKENDS: dict[str, str] = {
    "lcm": "spine_module.buses.lcm_backend",
    "inprocess": "spine_module.buses.inprocess_backend",
    "can": "spine_module.buses.cybergear",  # CyberGear CAN backend (its own issue)
}


def register(name: str, module: str) -> None:
    BACKENDS[name] = module


def backend_module(name: str):
    try:
        path = BACKENDS[name]
    except KeyError:
        raise ValueError(f"unknown motor backend {name!r}; known: {', '.join(sorted(BACKENDS))}") from None
    try:
        return importlib.import_module(path)
    except Exception as exc:
        raise ValueError(f"motor backend {name!r} ({path}) is not available: {exc!r}") from exc


def add_backend_arguments(parser: argparse.ArgumentParser) -> None:
    """Let every importable backend add its options (backends that fail to import are skipped)."""
    for name in BACKENDS:
        try:
            mod = backend_module(name)
        except Exception:  # a broken or missing backend must not take the other commands down
            continue
        add: Callable[[argparse.ArgumentParser], None] | None = getattr(mod, "add_arguments", None)
        if add is not None:
            add(parser)


def make_bus(name: str, args: argparse.Namespace, lc=None) -> MotorBus:
    mod = backend_module(name)
    factory = getattr(mod, "make_bus", None)
    if factory is None:
        raise ValueError(f"motor backend {name!r} has no make_bus(args, lc)")
    return factory(args, lc)
