"""Every leg controller is a `Gait`: the bound loop calls its optional members without probing."""

from __future__ import annotations

import pytest

from sparc_quad.gaits.base import Gait
from sparc_quad.gaits.bound import BoundController
from sparc_quad.gaits.bound_fast import CompiledBoundController
from sparc_quad.gaits.sine_bound import SineBoundController


@pytest.mark.parametrize("cls", [BoundController, CompiledBoundController, SineBoundController])
def test_gaits_subclass_gait(cls):
    assert Gait in cls.__mro__  # explicitly: the defaults are inherited, not only the shape matched
    for member in ("step", "start_pose", "observe_spine", "backend", "clock"):
        assert hasattr(cls, member), member
    for member in ("step", "phase_fraction", "frequency"):  # what the log needs: each gait its own
        assert getattr(cls, member) is not getattr(Gait, member), member


def test_gait_defaults():
    class Still(Gait):
        def __init__(self) -> None:
            self.stance_flags = {"hind": True, "front": True}

        def step(self, t):
            return {}

    g = Still()
    assert g.clock is None  # computed every step: the bound steps it in full
    with pytest.raises(NotImplementedError):  # a gait that does not say its phase is not logged as None
        g.phase_fraction()
    assert g.start_pose() is None
    assert g.observe_spine(0.0, 0.27) is None
    assert g.backend == "python"
    assert BoundController.start_pose is Gait.start_pose  # gait B stands, and has no spine observer
    assert BoundController.observe_spine is Gait.observe_spine
    assert CompiledBoundController.backend == "numba"
