"""Study report and claim checks on synthetic records with a known optimum."""

from __future__ import annotations

import json

import numpy as np
import pytest

from sparc_quad.study.claims import evaluate
from sparc_quad.study.records import write_record
from sparc_quad.study.report import ReportError, analyse, load_trials, write_report

KS = (300.0, 800.0, 1200.0, 2000.0)
DS = (2.0, 8.0, 20.0)


def synthetic_cot(spine: str, speed: float, k: float | None, d: float | None) -> float:
    """Rigid 1.0; at 0.9 m/s the impedance bowl bottoms at k = 900, d = 8 at 0.7 (30 % below rigid);
    at 0.4 m/s every cell is within 2 % of rigid; passive is 5 % above impedance."""
    if spine == "rigid":
        return 1.0
    if speed < 0.5:
        return 1.0 + 0.02 * np.tanh((k - 1000.0) / 1000.0)
    base = 0.7 + 0.4 * (np.log(k / 900.0)) ** 2 + 0.01 * abs(d - 8.0)
    return base * (1.05 if spine == "passive" else 1.0)


def make_study(folder, fall_cell=None, all_fall=False, n_seeds=10, rigid_ran=None):
    rng = np.random.default_rng(0)
    hashes = []
    n = 0
    for speed in (0.9, 0.4):
        cells = [("rigid", None, None)] + [
            (s, k, d) for s in ("impedance", "passive") for k in KS for d in DS
        ]
        for spine, k, d in cells:
            for seed in range(n_seeds):
                cfg = {
                    "gait": "sine",
                    "spine": spine,
                    "speed": speed,
                    "slope": 0.0,
                    "seed": seed,
                    "duration": 10.0,
                }
                if k is not None:
                    cfg.update(kx=k, dx=d)
                mean = synthetic_cot(spine, speed, k, d) * (1.0 + 0.2 * (seed % 3 - 1))  # seeds differ a lot
                strides = [{"cot_pos_total": float(mean + rng.normal(0, 0.005))} for _ in range(20)]
                fell = fall_cell == (spine, speed, k, d) or (all_fall and spine != "rigid")
                if all_fall and fell:  # a trial that fell before its steady window: every metric NaN
                    strides = [{"cot_pos_total": float("nan")}]
                m = {
                    "fell": fell,
                    "cot_pos_total": float(np.mean([s["cot_pos_total"] for s in strides])),
                    "speed_m_s": (rigid_ran or {}).get(speed, speed) if spine == "rigid" else speed,
                    "stride_length_m": 0.12,
                    "commanded_gait_frequency_hz": 3.1,
                    "strides": strides,
                }
                h = f"h{n:05d}"
                n += 1
                write_record(folder / "trials", {"hash": h, "config": cfg, "status": "ok", "metrics": m})
                hashes.append(h)
    (folder / "summary.json").write_text(json.dumps({"name": "synthetic", "hashes": hashes}))


def test_report_finds_the_known_optimum_and_pairs_by_seed(tmp_path):
    make_study(tmp_path)
    _, trials = load_trials(tmp_path)
    res = analyse(trials, n_boot=500)
    best = next(o for o in res["optima"] if o["spine"] == "impedance" and o["panel"].startswith("sine_0.9"))
    assert (best["best"]["k"], best["best"]["d"]) == (800.0, 8.0)  # nearest grid point to the bowl's bottom
    assert best["best"]["diff_pct"] == pytest.approx(
        100 * (synthetic_cot("impedance", 0.9, 800.0, 8.0) - 1), abs=0.5
    )
    # seeds scatter +-20 %, but pairing by seed keeps the difference's CI narrow
    assert best["best"]["diff_hi"] - best["best"]["diff_lo"] < 2.0
    assert (
        best["best"]["hi"] - best["best"]["lo"]
        > 10 * (best["best"]["diff_hi"] - best["best"]["diff_lo"]) / 100
    )


def test_claims_on_known_answers(tmp_path):
    make_study(tmp_path)
    _, trials = load_trials(tmp_path)
    rows = {(r["claim"], r["spine"]): r for r in evaluate(analyse(trials, n_boot=500))}
    # 800 is best; 1200 is 4 % dearer, which the seed-paired comparison resolves: only 800 is near
    assert rows[("C1", "impedance")]["verdict"] == "reproduced"
    assert rows[("C1", "impedance")]["near_best_k"] == [800.0]
    assert rows[("C2", "impedance")]["verdict"] == "not tested"  # no step_length: the stride is not imposed
    assert rows[("C3", "impedance")]["verdict"] == "reproduced"  # about -28 %
    assert rows[("C3", "passive")]["verdict"] == "reproduced"
    assert rows[("C4", "impedance")]["verdict"] == "reproduced"  # +-2 % at 0.4 m/s against a wide bowl


def test_c4_needs_both_baselines_on_speed(tmp_path):
    """The locked spine standing but 0.3 m/s slow at 0.9 m/s: no spread against it to compare, not tested
    (it was judged from the off-speed baseline before)."""
    make_study(tmp_path, rigid_ran={0.9: 0.6})
    _, trials = load_trials(tmp_path)
    rows = {(r["claim"], r["spine"]): r for r in evaluate(analyse(trials, n_boot=200))}
    r = rows[("C4", "impedance")]
    assert r["verdict"] == "not tested" and "on speed" in r["finding"], r


def test_falls_are_hatched_and_excluded(tmp_path):
    make_study(tmp_path, fall_cell=("impedance", 0.9, 800.0, 8.0))
    _, trials = load_trials(tmp_path)
    res = analyse(trials, n_boot=200)
    cell = next(
        c
        for c in res["cells"]
        if c.spine == "impedance"
        and c.k == 800.0
        and c.d == 8.0
        and c.panel.startswith("sine_0.9")
        and c.metric == "cot_pos_total"
    )
    assert cell.n_fell == 10 and cell.hatched and cell.est is None
    assert cell.fall_lo == pytest.approx(0.7225, abs=1e-3)  # Wilson 10/10
    best = next(o for o in res["optima"] if o["spine"] == "impedance" and o["panel"].startswith("sine_0.9"))
    assert (best["best"]["k"], best["best"]["d"]) != (800.0, 8.0)


def test_claims_when_every_compliant_trial_fell(tmp_path):
    make_study(tmp_path, all_fall=True)
    _, trials = load_trials(tmp_path)
    res = analyse(trials, n_boot=100)
    rows = evaluate(res)
    assert {r["verdict"] for r in rows} == {"not tested"}
    assert "120/120 trials fell" in rows[0]["finding"]
    cell = next(c for c in res["cells"] if c.spine == "passive" and c.metric == "cot_pos_total")
    assert cell.n_fell == cell.n == 10 and cell.fall_lo == pytest.approx(0.7225, abs=1e-3)


def test_write_report_outputs(tmp_path):
    make_study(tmp_path)
    paths = write_report(tmp_path, n_boot=200)
    names = {p.name for p in paths}
    assert {"cells.csv", "cells.json", "claims.json", "claims.md"} <= names
    assert any(n.startswith("heatmap_sine_0.9") for n in names)
    assert any(n.startswith("cot_vs_k_sine_0.4") for n in names)
    doc = json.loads((tmp_path / "report" / "cells.json").read_text())
    assert doc["done"] == 2 * 25 * 10
    assert "| C3: 21 % less power" in (tmp_path / "report" / "claims.md").read_text()


def test_two_study_folders_report_as_one(tmp_path):
    a, b = tmp_path / "a", tmp_path / "b"
    make_study(a)
    make_study(b)
    from sparc_quad.study.report import load_studies

    summary, trials = load_studies([a, b])
    _, one = load_trials(a)
    assert len(trials) == 2 * len(one) and summary["studies"] == [str(a), str(b)]


def test_report_errors(tmp_path):
    with pytest.raises(ReportError, match=r"summary\.json"):
        load_trials(tmp_path)
    (tmp_path / "summary.json").write_text(json.dumps({"hashes": ["nope"]}))
    with pytest.raises(ReportError, match="no successful trials"):
        load_trials(tmp_path)
