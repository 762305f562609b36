"""The study's trial function: spine variants, gait families, metrics, seeds."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from sparc_quad.bound.run import COLUMNS, BoundConfig, run_bound
from sparc_quad.metrics import COTS, GROUPS
from sparc_quad.sim.quadruped_world import WorldConfig
from sparc_quad.study.trial import run_trial
from spine_module import params as P

HEADLINE = [f"cot_{c}_{g}" for c in COTS for g in GROUPS] + [
    "speed_m_s", "stride_length_m", "stride_frequency_hz",
    "duty_mean", "flight_time_s", "spine_x_amplitude_m", "spine_theta_amplitude_rad", "spine_x_dominant_hz",
    "spine_x_dominant_over_gait", "spine_work_per_stride_j", "peak_leg_torque_nm", "leg_saturation_share",
    "peak_spine_torque_nm", "spine_saturation_share", "spine_torque_rms_nm", "fell", "fall_time_s",
    "fall_reason", "window_ok", "n_strides", "seed_mass_scale", "seed_friction",
]


@pytest.mark.parametrize(
    "gait,spine",
    [("raibert", "impedance"), ("raibert", "passive"), ("raibert", "rigid"), ("raibert", "rigid-impedance"),
     ("sine", "impedance"), ("sine", "passive")],
)
def test_every_variant_runs_and_returns_every_metric(gait, spine):
    m = run_trial({"gait": gait, "spine": spine, "duration": 1.5, "seed": 0, "settle": 0.2})
    missing = [k for k in HEADLINE if k not in m]
    assert not missing, missing
    assert isinstance(m["strides"], list) and m["strides"]
    assert {"cot_pos_total", "speed_m_s", "stride_frequency_hz", "spine_work_j"} <= set(m["strides"][0])
    assert m["spine"] == spine and m["gait"] == gait
    if not m["distance_m"] > 1e-3:  # no net forward distance in the window: no cost of transport
        assert all(math.isnan(m[k]) for k in ("cot_pos_spine", "cot_pos_total", "cot_pos_legs"))
    elif spine in ("passive", "rigid"):  # not an actuator: the spine costs nothing
        assert m["cot_pos_spine"] == 0.0 and m["cot_pos_total"] == m["cot_pos_legs"]
    else:
        assert m["cot_pos_spine"] > 0.0


def test_passive_spine_does_no_net_positive_work():
    m = run_trial({"gait": "raibert", "spine": "passive", "duration": 2.0, "settle": 0.2})
    # the spring-damper's work on the joints never exceeds the energy its spring released
    assert m["spine_work_plus_spring_energy_change_j"] < 1e-3
    for s in m["strides"]:
        assert s["spine_work_plus_spring_energy_change_j"] < 1e-3
    # the motor-rendered impedance of the same gains is not passive (it puts energy in)
    imp = run_trial({"gait": "raibert", "spine": "impedance", "duration": 2.0, "settle": 0.2})
    assert imp["spine_work_plus_spring_energy_change_j"] > 0.0


def test_locked_rigid_spine_does_not_move():
    r = run_bound(BoundConfig(duration_s=1.5, spine_variant="rigid", settle_s=0.2))
    assert not r.metrics["fell"]
    q = r.series[:, [COLUMNS.index(c) for c in ("q2", "q3", "q4")]]
    assert np.abs(q - P.Q_EQUILIBRIUM[1:]).max() < 1e-4
    assert not r.column("tau2").any()  # no actuator holds it


def test_seeds_change_the_trial():
    cot = [run_trial({"gait": "raibert", "duration": 2.0, "seed": s, "settle": 0.2})["cot_pos_total"]
           for s in (0, 1, 2)]
    assert len({round(c, 4) for c in cot}) == 3, cot
    a = run_trial({"gait": "raibert", "duration": 1.0, "seed": 3, "settle": 0.2})
    b = run_trial({"gait": "raibert", "duration": 1.0, "seed": 3, "settle": 0.2})
    assert a["cot_pos_total"] == b["cot_pos_total"]  # deterministic per seed


def test_short_window_is_flagged():
    with pytest.warns(RuntimeWarning, match="complete strides"):
        m = run_bound(BoundConfig(duration_s=0.1)).metrics
    assert m["window_ok"] is False and "strides" in m["warning"]


def test_fall_reason_keeps_the_first_fall():
    cfg = BoundConfig(duration_s=0.6, world=WorldConfig(init_pitch_rad=1.2), stop_on_fall=True)
    with pytest.warns(RuntimeWarning):
        first = run_bound(cfg)
        on = run_bound(replace(cfg, stop_on_fall=False))
    assert first.metrics["fell"] and first.metrics["fall_reason"] is not None
    assert len(on.series) > len(first.series)  # it ran on after the fall ...
    assert on.metrics["fell"] and on.metrics["fall_reason"] == first.metrics["fall_reason"]  # ... kept it
    assert on.metrics["fall_time_s"] == first.metrics["fall_time_s"]


def test_fall_reason_is_not_overwritten_by_later_steps(monkeypatch):
    from sparc_quad.bound import python_loop

    def scripted(world, pitch_front):  # falls at 5 ms, looks fine, then "falls" differently
        k = world.steps
        return "first" if k == 5 else ("later" if k > 100 else None)

    monkeypatch.setattr(python_loop, "fall_reason", scripted)
    with pytest.warns(RuntimeWarning):
        m = run_bound(BoundConfig(duration_s=0.3, stop_on_fall=False)).metrics
    assert m["fell"] and m["fall_reason"] == "first" and m["fall_time_s"] == pytest.approx(0.005)


def test_bad_config_is_named():
    with pytest.raises(ValueError, match="spine"):
        run_trial({"spine": "wobbly"})
    with pytest.raises(ValueError, match="bogus"):
        run_trial({"gait": "raibert", "bogus": 1})
    with pytest.raises(ValueError, match="kx"):
        run_trial({"kx": -5})
    with pytest.raises(ValueError, match="step_length"):
        run_trial({"gait": "raibert", "step_length": 0.1})


def test_natural_frequency_grows_as_root_k():
    from sparc_quad.sim.spine_resonance import spine_natural_frequency_hz

    lo, hi = spine_natural_frequency_hz(400.0), spine_natural_frequency_hz(1600.0)
    assert math.isfinite(lo) and lo > 0
    assert hi / lo == pytest.approx(2.0, rel=0.2)


def test_raibert_opt_objective_penalises_falls_and_speed():
    from sparc_quad.study.raibert_opt import objective

    ok = {"cot_pos_total": 0.8, "fell": False, "speed_m_s": 0.61}
    assert objective(ok, 0.6, 4.0) == pytest.approx(0.8)
    assert objective({**ok, "speed_m_s": 0.7}, 0.6, 4.0) > 0.8 + 3.0  # 7 cm/s off target
    assert objective({**ok, "fell": True, "fall_time_s": 1.0}, 0.6, 4.0) > 10.0
    early = objective({**ok, "fell": True, "fall_time_s": 0.5}, 0.6, 4.0)
    assert early > objective({**ok, "fell": True, "fall_time_s": 3.5}, 0.6, 4.0)


@pytest.mark.filterwarnings("ignore:steady window")
def test_raibert_opt_tunes_then_runs_and_a_tuned_gait_skips_the_search():
    from sparc_quad.study.raibert_opt import SEARCH, optimise_cell

    cfg = {"gait": "raibert-opt", "spine": "rigid", "duration": 1.0, "popsize": 2, "iterations": 1,
           "opt_duration": 6.0, "opt_restarts": 1, "opt_trial_seeds": 1, "settle": 0.2, "speed": 0.3}
    m = run_trial(cfg)
    assert m["gait"] == "raibert-opt" and m["opt_evaluations"] == 2.0
    for key, lo, hi in SEARCH:
        assert lo <= m[f"opt_{key}"] <= hi
    tuned = optimise_cell({**cfg, "seed": 5})  # same cell: cached, same answer
    assert tuned["frequency"] == m["opt_frequency"]
    again = run_trial({**cfg, "tuned": tuned})
    assert again["cot_pos_total"] == m["cot_pos_total"]
    with pytest.raises(ValueError, match="tuned"):
        run_trial({**cfg, "tuned": {"wobble": 1.0}})


def test_a_trial_that_falls_early_reports_every_metric_as_nan_and_stops_measuring_at_the_fall():
    cfg = {"gait": "raibert", "duration": 0.6, "settle": 0.0}
    import sparc_quad.bound.python_loop as loop

    real = loop.fall_reason
    try:
        loop.fall_reason = lambda world, pf: "scripted" if world.steps >= 50 else None
        with pytest.warns(RuntimeWarning):
            m = run_trial(cfg)
    finally:
        loop.fall_reason = real
    missing = [k for k in HEADLINE if k not in m]
    assert not missing, missing
    assert m["fell"] and m["fall_reason"] == "scripted" and math.isnan(m["cot_pos_total"])
    assert math.isnan(m["speed_m_s"]) and m["strides"] == []


@pytest.mark.filterwarnings("ignore:steady window")
def test_cli_bound_spine_variant_and_attitude_gain(tmp_path, capsys):
    import json

    from sparc_quad.cli import main

    out = tmp_path / "passive"
    assert main(["bound", "--spine", "passive", "--body-kp", "0", "--duration", "1.0",
                 "--out", str(out)]) == 0
    m = json.loads((out / "metrics.json").read_text())
    assert m["spine_variant"] == "passive" and m["spine_actuated"] is False
    assert m["config"]["gait"]["body_kp"] == 0.0
    assert main(["bound", "--spine", "passive", "--spine-path", "node", "--out", str(tmp_path / "n")]) == 2
    with pytest.raises(SystemExit) as exc:
        main(["bound", "--body-kp", "-1", "--out", str(tmp_path / "bad")])
    assert exc.value.code == 2 and "body-kp" in capsys.readouterr().err
