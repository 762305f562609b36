"""The metrics table: hand-built traces with known answers, contact-counted touchdowns, one saturation test,
no silent merge."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sparc_quad.metrics import TABLE, Context, label, measure, merge_disjoint, saturated
from sparc_quad.sim.bound_log import COLUMNS
from spine_module import params as P

COL = {c: k for k, c in enumerate(COLUMNS)}


def _ctx(actuated: bool = True, mass: float = 2.0) -> Context:
    return Context(dt_s=1e-3, mass_kg=mass, gravity_m_s2=P.GRAVITY_M_S2, slope_rad=0.0,
                   leg_torque_limit_nm=8.0, spine_torque_limit_nm=P.TORQUE_LIMIT_NM, spine_actuated=actuated)


def _series(n: int, dt: float, speed: float, freq: float) -> np.ndarray:
    s = np.zeros((n, len(COLUMNS)))
    t = np.arange(n) * dt
    s[:, COL["t"]] = t
    s[:, COL["x"]] = speed * t
    s[:, COL["gait_phase"]] = (t * freq) % 1.0
    s[:, COL["gait_frequency_hz"]] = freq
    s[:, COL["tau_HL_hfe"]] = 2.0  # constant 2 N*m
    s[:, COL["dq_HL_hfe"]] = np.sin(2 * np.pi * freq * t)  # P = 2 sin: +, - halves
    s[:, COL["tau2"]] = 1.0
    s[:, COL["dq2"]] = 0.5  # spine P = 0.5 W always positive
    return s


def test_every_metric_has_unit_label_definition():
    for m in TABLE.values():
        assert m.unit and m.label and m.definition and m.kind in ("block", "stride", "run"), m.name
    assert label("speed_m_s") == "mean speed (m/s)"


def test_costs_on_a_hand_built_power_trace():
    dt, speed, freq, dur = 1e-3, 0.5, 2.0, 3.0
    n = round(dur / dt)
    s = _series(n, dt, speed, freq)
    mass, g = 2.0, P.GRAVITY_M_S2
    m = measure(s, _ctx(), t_start_s=1.0)
    a = round(1.0 / dt)
    dist = speed * (n - 1 - a) * dt
    p_leg = 2.0 * np.sin(2 * np.pi * freq * np.arange(a, n) * dt)
    e_pos = np.clip(p_leg, 0, None).sum() * dt
    assert e_pos == pytest.approx(2.0 * 2 * freq * 2.0 / (2 * np.pi * freq), rel=2e-3)  # 2 s of 2 Hz
    assert m["cot_pos_legs"] == pytest.approx(e_pos / (mass * g * dist), rel=1e-9)
    assert m["cot_abs_legs"] == pytest.approx(np.abs(p_leg).sum() * dt / (mass * g * dist), rel=1e-9)
    assert m["cot_net_legs"] == pytest.approx(p_leg.sum() * dt / (mass * g * dist), abs=1e-6)
    c_leg = P.SOLO12_WINDING.loss_w_per_nm2
    e_el = np.clip(p_leg + c_leg * 4.0, 0, None).sum() * dt
    assert m["cot_elec_legs"] == pytest.approx(e_el / (mass * g * dist), rel=1e-9)
    assert m["cot_pos_spine"] == pytest.approx(0.5 * 2.0 / (mass * g * dist), rel=1e-3)  # 0.5 W for 2 s
    assert m["cot_pos_total"] == pytest.approx(m["cot_pos_legs"] + m["cot_pos_spine"], rel=1e-12)
    assert m["n_strides"] == 3 and m["window_ok"]  # 2 Hz over 2 s: 4 wraps -> 3 complete strides
    assert m["stride_frequency_hz"] == pytest.approx(2.0, rel=1e-3)
    assert m["stride_length_m"] == pytest.approx(speed / freq, rel=2e-3)
    assert m["strides"][0]["spine_work_j"] == pytest.approx(0.5 * 0.5, rel=1e-3)  # 0.5 s at 0.5 W
    passive = measure(s, _ctx(actuated=False), t_start_s=1.0)  # not an actuator: the spine costs nothing
    assert passive["cot_pos_spine"] == 0.0 and passive["spine_work_j"] == pytest.approx(m["spine_work_j"])
    heavier = measure(s, _ctx(mass=4.0), t_start_s=1.0)  # mass from the context, not a constant
    assert heavier["cot_pos_total"] == pytest.approx(0.5 * m["cot_pos_total"])


def test_touchdowns_are_counted_from_contact_not_the_gait_clock():
    dt, freq = 1e-3, 2.0
    s = _series(3000, dt, 0.5, freq)
    t = s[:, COL["t"]]
    one = ((t * freq) % 1.0) < 0.4  # one stance per stride
    s[:, COL["contact_HL"]] = one
    m = measure(s, _ctx(), t_start_s=1.0)
    assert m["touchdown_frequency_hz"] == pytest.approx(freq, rel=1e-3)
    assert m["hind_touchdowns_per_stride"] == pytest.approx(1.0)
    assert m["duty_HL"] == pytest.approx(0.4, abs=0.01)
    two = (((t * 2 * freq) % 1.0) < 0.4)  # the foot bounces: two touchdowns in each gait-clock stride
    s[:, COL["contact_HL"]] = two
    m = measure(s, _ctx(), t_start_s=1.0)
    assert m["stride_frequency_hz"] == pytest.approx(freq, rel=1e-3)  # the clock does not see it ...
    assert m["hind_touchdowns_per_stride"] == pytest.approx(2.0)  # ... the contact count does
    assert m["touchdown_frequency_hz"] == pytest.approx(2 * freq, rel=1e-3)


def test_saturation_is_read_against_the_context_limit():
    s = _series(3000, 1e-3, 0.5, 2.0)
    s[::2, COL["tau_FR_kfe"]] = 8.0  # at the leg limit half the time
    s[:, COL["tau3"]] = 11.0  # below the spine's 12 N*m
    m = measure(s, _ctx(), t_start_s=1.0)
    assert m["leg_saturation_share"] == pytest.approx(0.5, abs=1e-3)
    assert m["spine_saturation_share"] == 0.0
    ctx = Context(**{**_ctx().__dict__, "spine_torque_limit_nm": 11.0})
    assert measure(s, ctx, t_start_s=1.0)["spine_saturation_share"] == 1.0
    assert saturated(np.array([7.99, 8.0, -8.0]), 8.0).tolist() == [False, True, True]


def test_no_window_gives_every_metric_nan():
    with pytest.warns(RuntimeWarning, match="empty"):
        m = measure(np.zeros((0, len(COLUMNS))), _ctx(), t_start_s=0.0)
    assert set(TABLE) <= set(m) and all(math.isnan(m[k]) for k in TABLE)
    assert m["strides"] == [] and m["window_ok"] is False


def test_merge_refuses_a_key_defined_twice():
    assert merge_disjoint({"a": 1}, {"b": 2}) == {"a": 1, "b": 2}
    with pytest.raises(ValueError, match="speed_m_s"):
        merge_disjoint({"speed_m_s": 1.0}, {"speed_m_s": 2.0})
