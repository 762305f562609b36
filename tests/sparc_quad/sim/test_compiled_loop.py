"""The bound's compiled loop (`bound.compiled_loop`: the control half of each step in one compiled call)
against the Python loop on the same compiled controllers: the same series bit for bit, through clamps, the
joint-limit damping and falls; the pieces the kernel states again (the node's output stage, the torso
estimator) on their own; and the runs it leaves to the Python loop."""

from __future__ import annotations

import math
import warnings
from dataclasses import replace

import numpy as np
import pytest

from sparc_quad.bound import compiled_loop, step_kernel
from sparc_quad.bound.run import BoundConfig, run_bound
from sparc_quad.gaits.bound import BoundParams
from sparc_quad.sim.bound_log import COLUMNS
from sparc_quad.sim.imu import ImuConfig
from sparc_quad.sim.quadruped_world import Estimator, WorldConfig
from sparc_quad.sim.spine_drive import SpineGains
from spine_module import safety

pytest.importorskip("numba")

CASES = {
    "default": BoundConfig(duration_s=1.5, backend="numba"),
    "slope-backward-friction-delay-bias": BoundConfig(
        duration_s=1.2, backend="numba", friction_compensation=True, spine_torso_accel=False,
        gait=BoundParams(duty=0.4, speed_m_s=-0.3, pitch_kp=5.0, pitch_kd=0.5, start_s=0.1),
        world=WorldConfig(slope_rad=0.1, imu=ImuConfig(delay_steps=3, q1_bias_rad=0.01, accel_filter_hz=0.0)),
        spine=SpineGains(k=(200.0, 300.0, 5.0), d=(5.0, 5.0, 0.1))),
    "spined-dog-without-abduction": BoundConfig(duration_s=1.0, backend="numba",
                                                world=WorldConfig(host="spined-dog")),
    "rigid-impedance": BoundConfig(duration_s=0.8, backend="numba", spine_variant="rigid-impedance"),
    # a limp spine rests on its joint limits: the output stage's limit damping acts on most steps
    "limp-spine-on-its-limits": BoundConfig(duration_s=1.5, backend="numba",
                                            spine=SpineGains(k=(0.0, 0.0, 0.0), d=(0.0, 0.0, 0.0))),
    # launched at 3 m/s: the spine torque clamps at 12 N*m, then the robot pitches over
    "clamps-then-falls": BoundConfig(duration_s=1.0, backend="numba", world=WorldConfig(init_vx_m_s=3.0)),
    # crouched too low: the body touches the ground; the run goes on after it (stop_on_fall False)
    "falls-and-runs-on": BoundConfig(duration_s=0.8, backend="numba", stop_on_fall=False,
                                     gait=BoundParams(height_m=0.12)),
}


def _both(cfg: BoundConfig):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # a short run's metric warnings
        return run_bound(cfg), run_bound(cfg, compiled_loop=False)


def _same_metrics(a: dict, b: dict) -> list[str]:
    def same(x, y):  # NaN equals NaN, in lists of per-stride dicts too (a stride with no forward distance)
        return x == y or repr(x) == repr(y)

    return [k for k in a if k not in ("wall_time_s", "physics_wall_time_s", "loop") and not same(a[k], b[k])]


@pytest.mark.parametrize("name", list(CASES))
def test_compiled_loop_gives_the_python_loops_series_bit_for_bit(name):
    fast, ref = _both(CASES[name])
    assert fast.metrics["loop"] == "compiled" and ref.metrics["loop"] == "python"
    assert fast.series.shape == ref.series.shape
    bad = [COLUMNS[c] for c in np.flatnonzero(np.any(fast.series != ref.series, axis=0))]
    assert not bad, f"the compiled loop changed columns {bad}"
    assert fast.series.tobytes() == ref.series.tobytes()  # signed zeros too
    assert not _same_metrics(fast.metrics, ref.metrics)


def test_the_cases_reach_what_they_are_named_for():
    """The limits, the clamp and both falls are really exercised above (else those cases test nothing)."""
    lim = safety.TorqueLimits.from_config(safety.SafetyConfig())
    limp = run_bound(CASES["limp-spine-on-its-limits"])
    q = limp.series[:, [COLUMNS.index(c) for c in ("q2", "q3", "q4")]]
    lo, hi = np.array(lim.clear[0::2]), np.array(lim.clear[1::2])
    assert np.any((q < lo) | (q > hi), axis=1).mean() > 0.5
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        clamped = run_bound(CASES["clamps-then-falls"])
        runs_on = run_bound(CASES["falls-and-runs-on"])
    tau = clamped.series[:, [COLUMNS.index(c) for c in ("tau2", "tau3", "tau4")]]
    assert np.abs(tau).max() == lim.torque
    assert clamped.metrics["fell"] and clamped.metrics["fall_reason"] == "pitch beyond 1 rad"
    assert runs_on.metrics["fell"] and len(runs_on.series) == round(0.8 / 1e-3)
    assert runs_on.metrics["fall_reason"] == "body touched the ground"


def test_compiled_loop_on_mujocos_full_path():
    pytest.importorskip("mujoco")
    cfg = BoundConfig(duration_s=1.0, backend="numba", world=WorldConfig(engine="mujoco", host="spined-dog"))
    fast, ref = _both(cfg)
    assert fast.metrics["loop"] == "compiled"
    assert fast.series.tobytes() == ref.series.tobytes()


@pytest.mark.parametrize("change", [
    {"backend": "python"},
    {"spine_variant": "passive"},
    {"spine_rate_hz": 500.0},
    {"world": WorldConfig(base_motion="constant-twist")},
    {"actuator_latency_steps": 2},
], ids=["python-backend", "passive-spine", "clocked-spine", "constant-twist", "latency"])
def test_runs_it_cannot_compile_take_the_python_loop(change):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        m = run_bound(replace(BoundConfig(duration_s=0.2, backend="numba"), **change)).metrics
    assert m["loop"] == "python"


def test_why_not_names_what_stops_it():
    from sparc_quad.bound.run import direct_spine, make_gait
    from sparc_quad.sim.quadruped_world import make_world

    for cfg, words in ((BoundConfig(spine_variant="passive", backend="numba"), "spine"),
                       (BoundConfig(backend="numba", world=WorldConfig(base_motion="constant-twist")),
                        "constant-twist")):
        world = make_world(cfg.world)
        try:
            spine, gait = direct_spine(cfg), make_gait(world, cfg.gait, "numba")
            why = compiled_loop.CompiledLoop.why_not(world, spine, gait)
            assert why is not None and words in why
            with pytest.raises(ValueError, match="no compiled loop"):
                compiled_loop.CompiledLoop(world, spine, gait)
        finally:
            world.close()


def test_choose_loop_says_why_it_picked_each_loop():
    from sparc_quad.bound.loops import choose_loop
    from sparc_quad.bound.run import direct_spine, make_gait
    from sparc_quad.bound.stepping import Steps
    from sparc_quad.sim.quadruped_world import make_world

    for cfg, backend, want, words in (
            (BoundConfig(backend="numba"), "numba", "compiled", "compiled"),
            (BoundConfig(backend="numba", spine_variant="passive"), "numba", "python", "spine"),
            (BoundConfig(backend="python"), "python", "python", "per-step code is python")):
        world = make_world(cfg.world)
        try:
            gait = make_gait(world, cfg.gait, backend)
            s = Steps(world, direct_spine(cfg), gait, np.zeros((1, len(COLUMNS))))
            loop = choose_loop(s, backend)
            assert loop.name == want and words in loop.why, loop.why
            if want == "python":
                assert "cannot rewind" in loop.why  # pybullet: no held chunks either
            watched = choose_loop(replace(s, profile={}, latency=2), backend)
            assert watched.name == "python" and watched.why.startswith("profiling, actuator latency")
            assert "turned off" in choose_loop(s, backend, held_steps=False, compiled_loop=False).why
        finally:
            world.close()


def test_a_stop_request_interrupts_the_compiled_loop():
    calls = []

    def stop():
        calls.append(1)
        return len(calls) > 100

    with pytest.raises(KeyboardInterrupt):
        run_bound(BoundConfig(duration_s=1.0, backend="numba"), stop=stop)
    assert len(calls) == 101


def _limit_cases():
    rng = np.random.default_rng(7)
    lim = safety.TorqueLimits.from_config(safety.SafetyConfig())
    lo, hi = np.array(lim.lower), np.array(lim.upper)
    cases = []
    for _ in range(3000):
        q = rng.uniform(lo - 0.15, hi + 0.15)  # inside, in the margin, beyond the limits
        dq = rng.normal(0.0, 3.0, 3)
        tau = rng.normal(0.0, 10.0, 3)  # some beyond the 12 N*m clamp
        cases.append((*tau, *q, *dq))
    for bad in (math.nan, math.inf, -math.inf):  # a non-finite torque, angle or rate
        cases += [(bad, 1.0, -1.0, -0.5, 1.0, -0.5, 0.1, 0.1, 0.1),
                  (1.0, 2.0, 3.0, bad, 1.0, -0.5, 0.1, 0.1, 0.1),
                  (1.0, 2.0, 3.0, 0.15, 1.0, -0.5, bad, 0.1, 0.1)]
    cases += [(0.0, -0.0, 12.0, -1.65, 0.1, 0.1, 0.0, -0.0, 1.0),  # on the clear bounds, at the clamp
              (-12.0, 12.0000001, 0.0, 0.1, 2.8, -1.65, 0.0, 0.0, 0.0)]
    return lim, cases


def _same(x: float, y: float) -> bool:
    return (math.isnan(x) and math.isnan(y)) or (x == y and math.copysign(1, x) == math.copysign(1, y))


def test_kernel_output_stage_equals_safety_limit_torque():
    from numba import njit

    import sparc_quad.bound.step_compiled  # noqa: F401  (makes the kernel's helpers callable from compiled code)

    limit3 = step_kernel.limit_torque3

    @njit
    def compiled(a, b, c, qa, qb, qc, dqa, dqb, dqc, lim):
        return limit3(a, b, c, qa, qb, qc, dqa, dqb, dqc, lim)

    lim, cases = _limit_cases()
    arr = compiled_loop.limits_array(lim)
    with np.errstate(invalid="ignore"):  # inf * 0 in the Python run of the kernel (numpy scalars warn)
        _compare(cases, lim, arr, limit3, compiled)


def _compare(cases, lim, arr, limit3, compiled):
    for a, b, c, qa, qb, qc, dqa, dqb, dqc in cases:
        want = safety.limit_torque((a, b, c), (qa, qb, qc), (dqa, dqb, dqc), lim)[:3]
        for got in (limit3(a, b, c, qa, qb, qc, dqa, dqb, dqc, arr),
                    compiled(a, b, c, qa, qb, qc, dqa, dqb, dqc, arr)):
            assert all(_same(x, y) for x, y in zip(got, want, strict=True)), (a, b, c, qa, qb, qc, got, want)


def test_limits_array_needs_a_margin():
    lim = safety.TorqueLimits.of((-1, -1, -1), (1, 1, 1), 0.0, 0.5, 12.0)
    with pytest.raises(ValueError, match="margin"):
        compiled_loop.limits_array(lim)


def test_kernel_estimator_equals_estimator_update_and_hands_its_state_back():
    """Across a noise block and with a delay line: the kernel's estimate equals `Estimator.update` step for
    step, and an estimator given the kernel's state back goes on as one that never left Python."""
    imu = ImuConfig(delay_steps=2, q1_bias_rad=0.003, dq1_bias_rad_s=-0.02, accel_filter_hz=15.0)
    ref = Estimator(imu, 1e-3, np.random.default_rng(5))
    est = Estimator(imu, 1e-3, np.random.default_rng(5))
    rng = np.random.default_rng(1)
    states = rng.normal(0.0, 0.3, (2600, 2)).tolist()
    for q1, dq1 in states[:7]:
        ref.update(q1, dq1)
        est.update(q1, dq1)
    eprm = compiled_loop.estimator_params(est, True, 0.0)
    arr = np.zeros(step_kernel.ES_RING + 3 * est.delay_line_length)
    noise, k = compiled_loop.load_estimator(est, arr)
    for q1, dq1 in states[7:2500]:  # crosses two noise blocks
        if k == len(noise):
            noise, k = est.draw_noise(), 0
        got = step_kernel.estimate(eprm, arr, noise[k, 0], noise[k, 1], noise[k, 2], q1, dq1)
        k += 1
        want = ref.update(q1, dq1)
        assert got == (want.q1, want.dq1, want.ddq1)
    compiled_loop.save_estimator(est, arr, noise, k)
    for q1, dq1 in states[2500:]:
        a, b = est.update(q1, dq1), ref.update(q1, dq1)
        assert (a.q1, a.dq1, a.ddq1) == (b.q1, b.dq1, b.ddq1)
