"""What `run_bound` needs of a leg controller (`Gait`), with the defaults of its optional members.

Every gait subclasses `Gait` explicitly, so the optional members exist on each one and the bound loop calls
them without probing: a gait that does not start on its trajectory inherits `start_pose() -> None`, one
without a spine-driven adaptation the no-op `observe_spine`.
"""

from __future__ import annotations

from typing import Protocol


class Gait(Protocol):
    """A leg controller as a bound sees it."""

    stance_flags: dict[str, bool]  # "hind"/"front" -> commanded stance this step (logged)
    backend: str = "python"  # the per-step code: "python" | "numba"

    def step(self, t: float) -> dict[str, tuple[float, float, float]]:
        """Leg torques (N*m) for time `t` (s): {leg: (tau_haa, tau_hfe, tau_kfe)}, once per physics step."""
        ...

    def start_pose(self) -> tuple | None:
        """(spine q or None, leg angles, base height or None) for `world.set_start`; None: the stand."""
        return None

    def observe_spine(self, t: float, spine_x_m: float) -> None:
        """After each `step`: the spine extension x (m) the spine computed at `t` (s). Default: unused."""
        return None
