"""What `run_bound` needs of a leg controller (`Gait`), with the defaults of its optional members.

Every gait subclasses `Gait` explicitly, so the optional members exist on each one and the bound loop calls
them without probing: a gait that does not start on its trajectory inherits `start_pose() -> None`, one
without a spine-driven adaptation the no-op `observe_spine`.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Protocol

if TYPE_CHECKING:
    from sparc_quad.sim.control_clock import ControlClock


class Gait(Protocol):
    """A leg controller as a bound sees it."""

    stance_flags: dict[str, bool]  # "hind"/"front" -> commanded stance this step (logged)
    backend: str = "python"  # the per-step code: "python" | "numba"
    clock: ControlClock | None = None  # a gait computed only at its clock's calls (torques held between)

    def phase_fraction(self) -> float:
        """Where in its stride cycle the gait is, in [0, 1) (logged as `gait_phase`)."""
        raise NotImplementedError

    def frequency(self) -> float:
        """Stride frequency now, Hz (logged as `gait_frequency_hz`)."""
        raise NotImplementedError

    def step(self, t: float) -> dict[str, tuple[float, float, float]]:
        """Leg torques (N*m) for time `t` (s): {leg: (tau_haa, tau_hfe, tau_kfe)}, once per physics step."""
        raise NotImplementedError

    def start_pose(self) -> tuple | None:
        """(spine q or None, leg angles, base height or None) for `world.set_start`; None: the stand."""
        return None

    def observe_spine(self, t: float, spine_x_m: float) -> None:
        """After each `step`: the spine extension x (m) the spine computed at `t` (s). Default: unused."""
        return None
