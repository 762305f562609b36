"""Gait A's compiled joint PD (`gaits.sine_kernel.pd_step`, numba) gives the Python path's doubles, bit for
bit: on random states, and over a whole bound of the spined dog (the open-loop bound's outcome flips on
differences far below a round-off, so "close" would not do)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from sparc_quad.bound.run import direct_spine, make_gait, run_bound
from sparc_quad.gaits import sine_kernel
from sparc_quad.sim.quadruped_world import make_world
from tests.scenarios import authors_config

pytest.importorskip("numba")
LEGS = ("HL", "HR", "FL", "FR")


@pytest.fixture(scope="module")
def gaits():
    cfg = authors_config(step_length_m=0.08, k_x_n_m=800.0, duration_s=2.0, engine="mujoco")
    world = make_world(cfg.world)
    yield world, make_gait(world, cfg.gait, "python"), make_gait(world, cfg.gait, "numba")
    world.close()


def test_compiled_and_python_kernel_equal_the_python_gait_bit_for_bit(gaits):
    world, ref, fast = gaits
    assert ref.backend == "python" and fast.backend == "numba"
    rng = np.random.default_rng(7)
    out = np.zeros((4, 3))
    for i in range(2000):
        jq, jdq = rng.normal(0.0, 1.0, len(world.jq)), rng.normal(0.0, 5.0, len(world.jdq))
        jq[-1] = jdq[-1] = 0.0  # the absent joints' slot
        world.jq, world.jdq = jq.tolist(), jdq.tolist()
        phase, amp = float(rng.uniform(-20.0, 20.0)), 1.0 if i % 2 else float(rng.uniform(0.0, 1.0))
        scale = {"L": float(rng.uniform(0.6, 1.4)), "R": float(rng.uniform(0.6, 1.4))}
        ref.stride_scale, fast.stride_scale = dict(scale), dict(scale)
        ref._pd(phase, amp, True)
        fast._pd(phase, amp, True)
        assert [fast.out[k] for k in LEGS] == [ref.out[k] for k in LEGS]
        assert fast.stance_flags == ref.stance_flags
        # the kernel as plain Python (what numba compiles) too
        sine_kernel.pd_step(phase, amp, scale["L"], scale["R"], jq, jdq, fast._legs_arr, fast._gains_arr, out)
        assert [tuple(r) for r in out.tolist()] == [ref.out[k] for k in LEGS]


def test_a_bound_on_the_compiled_gait_is_the_python_bound_to_the_bit():
    cfg = authors_config(step_length_m=0.08, k_x_n_m=800.0, duration_s=3.0, engine="mujoco")
    fast = replace(cfg, backend="numba")
    # the same (compiled) spine step in both: only the gait's backend differs
    a = run_bound(replace(cfg, backend="python"), spine=direct_spine(fast))
    b = run_bound(fast)
    assert a.metrics["gait_backend"] == "python" and b.metrics["gait_backend"] == "numba"
    assert a.metrics["spine_backend"] == b.metrics["spine_backend"] == "numba"
    assert a.series.tobytes() == b.series.tobytes()
