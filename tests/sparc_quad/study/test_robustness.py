"""The frequency window (study/robustness.py): per spine cell, the frequencies where at least 80 % of the
seeds stood, from panels that differ only in the gait frequency."""

from __future__ import annotations

from sparc_quad.study.report import Trial, analyse
from sparc_quad.study.robustness import frequency_windows, markdown


def _trials(spine: str, falls_at: dict[float, int], seeds: int = 10) -> list[Trial]:
    out = []
    for f, n_fell in falls_at.items():
        for s in range(seeds):
            fell = s < n_fell
            cfg = {"gait": "sine", "host": "spined-dog", "frequency": f, "spine": spine, "seed": s}
            m = {"fell": fell, "cot_pos_total": float("nan") if fell else 0.5 + 0.01 * s,
                 "speed_m_s": 0.3 * f, "strides": []}
            out.append(Trial(cfg, m, True, fell))
    return out


def test_window_is_where_most_seeds_stand():
    trials = (_trials("rigid", {2.8: 10, 2.9: 3, 3.0: 0, 3.1: 1, 3.2: 6})
              + _trials("passive", {2.8: 0, 2.9: 0, 3.0: 2, 3.1: 0, 3.2: 0}))
    rows = {r["spine"]: r for r in frequency_windows(analyse(trials, n_boot=50))}
    assert rows["rigid"]["window_hz"] == [3.0, 3.1] and rows["rigid"]["contiguous"]
    assert rows["passive"]["window_hz"] == [2.8, 3.2] and rows["passive"]["frequencies_standing"] == 5
    at = {p["frequency_hz"]: p for p in rows["rigid"]["points"]}
    assert at[2.8]["n_fell"] == 10 and at[2.8]["fall_lo"] > 0.6  # Wilson interval of 10/10
    text = markdown(list(rows.values()))
    assert "3-3.1 Hz" in text or "3-3.1" in text
    assert "10/10" in text


def test_gaps_are_said():
    trials = _trials("rigid", {2.8: 0, 2.9: 9, 3.0: 0})
    (row,) = frequency_windows(analyse(trials, n_boot=50))
    assert row["window_hz"] == [2.8, 3.0] and not row["contiguous"]
    assert "with gaps" in markdown([row])


def test_no_frequency_factor_no_rows():
    trials = _trials("rigid", {3.1: 0})
    assert frequency_windows(analyse(trials, n_boot=50)) == []
