"""The bound's compiled per-step paths (numba spine step and bound controller) against the reference paths,
the "auto" rule, and the reference path against a trajectory recorded before the loop was optimised."""

from __future__ import annotations

import numpy as np
import pytest

from sparc_quad.bound import run as bound_run
from sparc_quad.bound.backend import NUMBA_PAYBACK_SIM_S, resolve_backend
from sparc_quad.bound.run import BoundConfig, run_bound
from sparc_quad.gaits.base import Gait
from sparc_quad.gaits.bound import BoundController, BoundParams
from sparc_quad.sim.quadruped_world import WorldConfig
from sparc_quad.sim.spine_drive import ImpedanceSpine, SpineGains
from tests.paths import DATA

pytest.importorskip("numba")

REFERENCE = DATA / "bound_reference_1s.npz"


class _Shadow(Gait):
    """Gait B by the reference controller; the compiled one is stepped on the same states beside it."""

    def __init__(self, world, params):
        from sparc_quad.gaits.bound_fast import CompiledBoundController

        self.ref = BoundController(world, params)
        self.comp = CompiledBoundController(world, params)
        self.p, self.stance_flags = self.ref.p, self.ref.stance_flags
        self.max_diff, self.steps, self.mismatch = 0.0, 0, []

    def phase_fraction(self) -> float:
        return self.ref.phase

    def frequency(self) -> float:
        return self.ref.p.frequency_hz

    def step(self, t: float):
        a, b = self.ref.step(t), self.comp.step(t)
        diff = max(abs(x - y) for k in a for x, y in zip(a[k], b[k], strict=True))
        self.max_diff = max(self.max_diff, diff)
        if self.comp.stance_flags != self.ref.stance_flags or self.comp.phase != self.ref.phase:
            self.mismatch.append(t)
        self.steps += 1
        return a


@pytest.mark.parametrize("cfg", [
    BoundConfig(duration_s=1.2),
    BoundConfig(duration_s=0.8, gait=BoundParams(duty=0.4, speed_m_s=-0.3, pitch_kp=5.0, pitch_kd=0.5,
                                                 start_s=0.1), world=WorldConfig(slope_rad=0.1)),
], ids=["default", "slope-fixed-duty-backward"])
def test_compiled_bound_controller_equals_the_reference_every_step(cfg, monkeypatch):
    shadows: list[_Shadow] = []

    def make(world, params, backend="python"):
        shadows.append(_Shadow(world, params))
        return shadows[-1]

    monkeypatch.setattr(bound_run, "make_gait", make)
    run_bound(replace_backend(cfg, "python"))
    (s,) = shadows
    assert s.steps == round(cfg.duration_s / cfg.world.dt_s)
    assert s.max_diff < 1e-9
    assert not s.mismatch


def replace_backend(cfg: BoundConfig, backend: str) -> BoundConfig:
    from dataclasses import replace

    return replace(cfg, backend=backend)


def test_compiled_spine_drive_equals_pinocchio_on_random_states():
    rng = np.random.default_rng(3)
    for friction in (False, True):
        ref = ImpedanceSpine(SpineGains(), friction=friction, backend="pinocchio")
        fast = ImpedanceSpine(SpineGains(), friction=friction, backend="numba")
        assert (ref.backend, fast.backend) == ("pinocchio", "numba")
        for _ in range(300):
            q = np.array([0.0, 0.1, -0.2, 0.1]) + 0.3 * rng.standard_normal(4)
            dq = 2.0 * rng.standard_normal(4)
            ddq1 = float(rng.standard_normal())
            a, b = ref.step(q, dq, ddq1).copy(), fast.step(q, dq, ddq1)
            np.testing.assert_allclose(b, a, rtol=0, atol=1e-9)
            np.testing.assert_allclose(fast.x, ref.x, rtol=0, atol=1e-9)
            np.testing.assert_allclose(fast.dx, ref.dx, rtol=0, atol=1e-9)


def test_whole_bound_numba_and_python_backends_agree_over_half_a_second():
    a = run_bound(BoundConfig(duration_s=0.5, backend="python"))
    b = run_bound(BoundConfig(duration_s=0.5, backend="numba"))
    assert (a.metrics["spine_backend"], a.metrics["gait_backend"]) == ("pinocchio", "python")
    assert (b.metrics["spine_backend"], b.metrics["gait_backend"]) == ("numba", "numba")
    np.testing.assert_allclose(b.series, a.series, rtol=0, atol=1e-8)


def test_reference_path_reproduces_the_trajectory_recorded_before_the_loop_was_optimised():
    ref = np.load(REFERENCE)
    r = run_bound(BoundConfig(duration_s=1.0, backend="python"))
    assert list(ref["columns"]) == list(bound_run.COLUMNS)
    np.testing.assert_allclose(r.series[::25], ref["series"], rtol=0, atol=1e-9)


def test_auto_rule_is_a_function_of_the_run_length():
    assert resolve_backend("auto", 1.0) == "python"
    assert resolve_backend("auto", NUMBA_PAYBACK_SIM_S) == "numba"
    assert resolve_backend("python", 100.0) == "python"
    assert resolve_backend("numba", 0.1) == "numba"
    with pytest.raises(ValueError, match="backend must be one of"):
        resolve_backend("fortran", 1.0)
