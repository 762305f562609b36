"""What the rig and the torso computer do during a run: the spine command to send and the push on the
end effector (a `sim.forces.ForceLaw`)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from sparc_quad.sim.forces import ForceLaw, push_pull
from spine_module.messages import SpineCommand

__all__ = ["BenchScript", "ForceLaw", "push_pull"]


@dataclass
class BenchScript:
    """The spine command the torso computer sends (None: none; a function of robot time s: a moving
    target) and the push on the end effector."""

    command: SpineCommand | Callable[[float], SpineCommand] | None = None
    force: ForceLaw | None = None
    duration_s: float = 1.0
