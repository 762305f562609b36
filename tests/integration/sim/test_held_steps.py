"""Held steps (the engine stepped with its controls as they are between the gait's control calls, the log
rows completed after the loop) against every step through the full path: the same series bit for bit."""

from __future__ import annotations

import warnings
from dataclasses import replace

import numpy as np
import pytest

from sparc_quad.bound.run import fill_held_rows, run_bound
from sparc_quad.sim.bound_log import COLUMNS
from sparc_quad.sim.quadruped_world import HELD_STATE, make_world
from tests.scenarios import authors_config
from tests.scenarios import trial_config as bound_config

pytest.importorskip("mujoco")


def _both(cfg):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # a short run's metric warnings
        return run_bound(cfg, held_steps=True), run_bound(cfg, held_steps=False)


def _assert_same(held, full, chunks: bool = True):
    if chunks:
        assert held.metrics["held_steps"] > 0.7 * len(held.series)  # most steps of the authors' 5 ms clock
    else:  # a world that cannot rewind runs every step in full
        assert held.metrics["held_steps"] == 0
    assert full.metrics["held_steps"] == 0
    assert held.series.shape == full.series.shape
    bad = [COLUMNS[c] for c in np.flatnonzero(np.any(held.series != full.series, axis=0))]
    assert not bad, f"held steps changed columns {bad}"
    assert held.series.tobytes() == full.series.tobytes()  # signed zeros too
    for k in ("fell", "fall_time_s", "speed_m_s", "simulated_s"):
        assert held.metrics[k] == full.metrics[k] or (held.metrics[k] != held.metrics[k]
                                                      and full.metrics[k] != full.metrics[k])


@pytest.mark.parametrize("engine", ["mujoco", "pybullet"])
def test_held_steps_bit_identical_study_trial(engine):
    """The study's trial (noise, seed perturbation, spine schedule, frequency adaptation); pybullet, which
    cannot rewind, runs it in full."""
    if engine == "pybullet":
        pytest.importorskip("pybullet")
    cfg = bound_config({"gait": "sine", "variant": "authors", "host": "spined-dog", "engine": engine,
                        "duration": 3.0, "step_length": 0.08, "kx": 300.0, "seed": 3})
    _assert_same(*_both(cfg), chunks=engine == "mujoco")


@pytest.mark.parametrize("base_motion", ["authors-cvel", "constant-twist", "fixed"])
def test_held_steps_bit_identical_through_a_fall(base_motion):
    """The authors' run at L = 0.12 m falls; stop_on_fall ends both runs at the same step. Every base
    motion: the constant-twist estimate needs each held state's twist, the authors' each held step's cvel
    (`step_chunk`'s)."""
    cfg = authors_config(step_length_m=0.12, k_x_n_m=800.0, duration_s=5.0, base_motion=base_motion)
    held, full = _both(cfg)
    assert held.metrics["fell"]
    _assert_same(held, full)


@pytest.mark.parametrize("base_motion", ["authors-cvel", "constant-twist"])
def test_held_steps_bit_identical_with_the_base_acceleration_at_l_0_08(base_motion):
    """L = 0.08 m, k_x 800 for 6 s (through the switch and the frequency adaptation), the authors' cvel (the
    run's default) and the true twist."""
    cfg = authors_config(step_length_m=0.08, k_x_n_m=800.0, duration_s=6.0, base_motion=base_motion)
    assert authors_config().world.base_motion == "authors-cvel"  # the scenario's default there
    held, full = _both(cfg)
    assert not held.metrics["fell"]
    _assert_same(held, full)
    for other in {"fixed", "constant-twist", "authors-cvel"} - {base_motion}:
        run = run_bound(replace(cfg, world=replace(cfg.world, base_motion=other)))
        assert run.series.tobytes() != held.series.tobytes()  # the estimate's acceleration reached the law


def _held_values(w) -> list[float]:
    cf = w.contact_force
    return [*w.base_pos, *w.q_spine, *w.dq_spine,
            *(float(cf[leg] > 0.0) for leg in ("HL", "HR", "FL", "FR")), *w.leg_rates()]


_TAU = ([0.3, -0.2, 0.1], {k: (0.0, 1.5, -2.0) for k in ("HL", "HR", "FL", "FR")})


def _chunk_against_steps(a, b, k: int) -> np.ndarray:
    """World b runs a chunk of k steps, world a (the same world) k plain steps: state by state the same;
    b's kept rows are returned."""
    a.set_torques(*_TAU)
    b.set_torques(*_TAU)
    b.start_held(k + 1)
    want = []
    for st in b.step_chunk(k, 0):
        a.step()
        est = a.estimator
        twist = (a.authors_twist() if est.uses_authors_twist else a.base_twist()) if est.needs_twist else None
        # the spine's q and dq as tuples in both, as the engines' `read` keeps them
        assert st == (a.t, a.q1, a.dq1, a.roll, a.yaw, a.q_spine, a.dq_spine, a.body_contact,
                      twist)
        want.append(_held_values(a))
    got = b.held_rows(np.arange(1, k + 1))
    assert got.tolist() == want
    return got


@pytest.mark.parametrize("base_motion", ["authors-cvel", "constant-twist"])
def test_mujoco_chunk_keeps_what_read_gives(base_motion):
    """MuJoCo's chunk (steps back to back, raw states converted after) gives, state by state, what `step` +
    `read` give (the twist too: the authors' cvel or the body twist); `rewind` takes it back to a state
    exactly."""
    cfg = authors_config(step_length_m=0.08, k_x_n_m=800.0, duration_s=1.0, base_motion=base_motion)
    a, b, c = make_world(cfg.world), make_world(cfg.world), make_world(cfg.world)
    assert b.can_rewind and b.estimator.needs_twist
    assert b.estimator.uses_authors_twist == (base_motion == "authors-cvel")
    got = _chunk_against_steps(a, b, 200)
    assert any(got[:, HELD_STATE.index("contact_HL")] > 0.5)  # the feet touched: the flags were exercised
    assert any(got[:, HELD_STATE.index("contact_HL")] < 0.5)
    assert (b.jq, b.jdq, b.base_rot, b.base_omega, b.contact_force) == (
        a.jq, a.jdq, a.base_rot, a.base_omega, a.contact_force)
    c.set_torques(*_TAU)
    for _ in range(57):
        c.step()
    b.rewind(57)
    assert (b.t, b.jq, b.jdq, b.contact_force) == (c.t, c.jq, c.jdq, c.contact_force)
    assert b.authors_twist() == c.authors_twist()  # cvel after the rewind's last step, as after c's


def test_a_world_that_cannot_rewind_is_stepped_in_full():
    """pybullet cannot take back part of a chunk: the bound steps every step through the full path."""
    pytest.importorskip("pybullet")
    cfg = authors_config(step_length_m=0.08, k_x_n_m=800.0, duration_s=0.3, engine="pybullet")
    with make_world(cfg.world) as w:
        assert not w.can_rewind
    assert run_bound(cfg).metrics["held_steps"] == 0


def test_chunk_rewinds_when_the_spine_torque_changes():
    """A spine on another clock than the gait's changes its torque inside chunks: each such step rewinds
    the world and runs in full, and the series is still the full path's."""
    from dataclasses import replace

    base = bound_config({"gait": "sine", "variant": "authors", "host": "spined-dog", "engine": "mujoco",
                         "duration": 2.0, "step_length": 0.08, "kx": 800.0, "seed": 1})
    cfg = replace(base, spine_rate_hz=300.0)  # 3.33 ms: calls between the gait's 5 ms calls
    held, full = _both(cfg)
    assert held.metrics["held_steps"] > 0.3 * len(held.series)
    assert held.series.tobytes() == full.series.tobytes()


def test_fill_held_rows_copies_the_held_row_and_packs_the_rest():
    class _World:
        def held_rows(self, rows):
            return np.array([np.arange(200, 200 + len(HELD_STATE))] * len(rows), dtype=float)

    series = np.arange(3 * len(COLUMNS), dtype=float).reshape(3, len(COLUMNS))
    aux = np.full((3, 16), -1.0)
    aux[2] = [0.0, *range(100, 115)]
    before = series.copy()
    fill_held_rows(series, _World(), aux)
    assert np.array_equal(series[:2], before[:2])
    assert series[2, COLUMNS.index("tau3")] == before[0, COLUMNS.index("tau3")]
    assert series[2, COLUMNS.index("t")] == 100.0
    assert series[2, COLUMNS.index("yaw")] == 104.0
    assert series[2, COLUMNS.index("q3")] == 200 + HELD_STATE.index("q3")


def test_a_spine_computed_every_step_runs_every_step_in_full():
    """A spine drive without a control clock (its torque may move every step) gets no chunks."""
    from dataclasses import replace

    cfg = replace(authors_config(step_length_m=0.08, k_x_n_m=800.0, duration_s=0.5),
                  spine_rate_hz=None, spine_timing="hold")
    held, full = _both(cfg)
    _assert_same(held, full, chunks=False)
