"""Physics engines of the quadruped world, chosen by name (as python-can chooses its interfaces): each
entry names its module, its class and the extra that installs the engine. Nothing is imported until a
world of that engine is made, so a process pays only for the engine it uses."""

from __future__ import annotations

import importlib
import os
from dataclasses import dataclass

# MuJoCo picks its OpenGL backend when it is first imported: without a display, EGL (headless rendering,
# `render()` and `bound --video`). This package is imported before its backends, so this runs first
# unless the process imported mujoco itself earlier.
if "MUJOCO_GL" not in os.environ and not os.environ.get("DISPLAY"):
    os.environ["MUJOCO_GL"] = "egl"


@dataclass(frozen=True)
class Engine:
    module: str
    cls: str
    package: str  # the top-level module the engine needs
    extra: str  # the pip extra that installs it


ENGINES: dict[str, Engine] = {
    "pybullet": Engine("sparc_quad.sim.engines.pybullet_world", "PybulletWorld", "pybullet", "sim"),
    "mujoco": Engine("sparc_quad.sim.engines.mujoco_world", "MujocoWorld", "mujoco", "mujoco"),
}
DEFAULT_ENGINE = "pybullet"


class EngineUnavailable(ModuleNotFoundError):
    """The engine's package is not installed: the message names the extra that installs it."""


def engine_error(name: str) -> str | None:
    """None when `name` is a known engine whose package imports; else the one-line reason."""
    if name not in ENGINES:
        return f"engine must be one of {', '.join(ENGINES)}, got {name!r}"
    import importlib.util

    e = ENGINES[name]
    try:
        found = importlib.util.find_spec(e.package) is not None
    except (ValueError, ImportError):  # sys.modules[package] is None: blocked (as tests do)
        found = False
    if not found:
        return f"engine {name!r} needs the [{e.extra}] extra (module {e.package!r} is not installed): " \
               f"pip install 'sparc-quad[{e.extra}]'"
    return None


def world_class(name: str):
    """The world class of engine `name`, imported now."""
    if name not in ENGINES:
        raise ValueError(engine_error(name))
    e = ENGINES[name]
    try:
        mod = importlib.import_module(e.module)
    except ModuleNotFoundError as exc:
        if (exc.name or "").split(".")[0] != e.package:
            raise
        raise EngineUnavailable(engine_error(name) or str(exc), name=e.package) from exc
    return getattr(mod, e.cls)
