"""Held steps (the engine stepped with its controls as they are between the gait's control calls, the log
rows completed after the loop) against every step through the full path: the same series bit for bit."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from sparc_quad.gaits import authors_run
from sparc_quad.sim.bound_log import COLUMNS
from sparc_quad.sim.bound_run import fill_held_rows, run_bound
from sparc_quad.sim.quadruped_world import HELD_STATE, make_world
from sparc_quad.study.fixed_trial import bound_config

pytest.importorskip("mujoco")


def _both(cfg):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # a short run's metric warnings
        return run_bound(cfg, held_steps=True), run_bound(cfg, held_steps=False)


def _assert_same(held, full):
    assert held.metrics["held_steps"] > 0.7 * len(held.series)  # most steps of the authors' 5 ms clock
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
    """The study's trial (noise, seed perturbation, spine schedule, frequency adaptation off at 3 s)."""
    if engine == "pybullet":
        pytest.importorskip("pybullet")
    cfg = bound_config({"gait": "sine", "variant": "authors", "host": "spined-dog", "engine": engine,
                        "duration": 3.0, "step_length": 0.08, "kx": 300.0, "seed": 3})
    _assert_same(*_both(cfg))


def test_held_steps_bit_identical_through_a_fall():
    """The authors' run at L = 0.12 m falls; stop_on_fall ends both runs at the same step."""
    held, full = _both(authors_run.bound_config(step_length_m=0.12, k_x_n_m=800.0, duration_s=5.0))
    assert held.metrics["fell"]
    _assert_same(held, full)


def test_mujoco_step_held_packs_what_read_gives():
    """MuJoCo's held step (no torque copy, a partial state read) packs and sets what `step` + `read` do."""
    cfg = authors_run.bound_config(step_length_m=0.08, k_x_n_m=800.0, duration_s=1.0)
    a, b = make_world(cfg.world), make_world(cfg.world)
    tau = ([0.3, -0.2, 0.1], {k: (0.0, 1.5, -2.0) for k in ("HL", "HR", "FL", "FR")})
    a.set_torques(*tau)
    b.set_torques(*tau)
    a.step()
    b.step()
    out = np.zeros((200, len(HELD_STATE)))
    for k in range(200):
        a.step()
        b.step_held(out, k * out.itemsize * out.shape[1])
        cf = a.contact_force
        want = [*a.base_pos, a.q1, a.dq1, a.roll, a.yaw, *a.q_spine, *a.dq_spine,
                *(float(cf[leg] > 0.0) for leg in ("HL", "HR", "FL", "FR")), *a.leg_rates()]
        assert out[k].tolist() == want
        assert (b.t, b.q1, b.dq1, b.roll, b.q_spine, b.dq_spine, b.body_contact) == (
            a.t, a.q1, a.dq1, a.roll, a.q_spine, a.dq_spine, a.body_contact)
    assert any(out[:, HELD_STATE.index("contact_HL")] > 0.5)  # the feet touched: the flags were exercised
    b.read()
    assert (b.jq, b.jdq, b.base_rot, b.base_omega) == (a.jq, a.jdq, a.base_rot, a.base_omega)


def test_fill_held_rows_copies_the_held_row_and_packs_the_rest():
    series = np.arange(3 * len(COLUMNS), dtype=float).reshape(3, len(COLUMNS))
    aux = np.full((3, 12), -1.0)
    aux[2] = [0.0, *range(100, 111)]
    state = np.zeros((3, len(HELD_STATE)))
    state[2] = np.arange(200, 200 + len(HELD_STATE))
    before = series.copy()
    fill_held_rows(series, state, aux)
    assert np.array_equal(series[:2], before[:2])
    assert series[2, COLUMNS.index("tau3")] == before[0, COLUMNS.index("tau3")]
    assert series[2, COLUMNS.index("t")] == 100.0
    assert series[2, COLUMNS.index("yaw")] == 200 + HELD_STATE.index("yaw")
