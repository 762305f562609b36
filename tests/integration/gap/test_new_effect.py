"""Adding an effect takes one class: a made-up kind (quadratic drag) registered here goes through
`gap synth` (hidden), the identification and the selection (named on its joint with its parameter) and the
report (plots, report.md), with nothing else changed."""

from __future__ import annotations

from typing import ClassVar

import numpy as np
import pytest

from sparc_quad.effects import Effect, EffectKind, Param, PlantEffects, kind, register, unregister
from sparc_quad.effects.base import joint_put
from tests.gap_helpers import check_named, run_case


class QuadraticDrag(EffectKind):
    NAME = "quadratic_drag"
    DOC = "friction -c dq |dq| (a fluid-like drag)"
    PARAMS = (Param("c_nm_s2_rad2", "N*m*s^2/rad^2", "drag coefficient"),)
    AMPLITUDE = "c_nm_s2_rad2"
    SYNTH_DEFAULTS: ClassVar[dict] = {"c_nm_s2_rad2": 0.05}

    @classmethod
    def friction(cls, state, law, torque, slope):
        return torque - state * law.dq * np.abs(law.dq), slope + 2.0 * state * np.abs(law.dq)

    @classmethod
    def column(cls, lib, term, bi):
        b = lib.blocks[bi]  # friction over a step: f(dq) + f'(dq) (dq_k+1 - dq_k) / 2, as the plant's
        ja = lib.robot.actuated.index(term.joint)
        dq, half = b.dq_act_raw[:, ja], b.half_step_dq[:, ja]
        col = b.F(dq * np.abs(dq) + 2.0 * np.abs(dq) * half)
        return joint_put(b, lib.robot.nv, lib.joint_v(term.joint), col)

    @classmethod
    def plausible(cls, p, sc, total_mass_kg):
        return None if p["c_nm_s2_rad2"] > 0 else "drag must be positive"


@pytest.fixture
def drag():
    register(QuadraticDrag)
    yield QuadraticDrag
    unregister(QuadraticDrag.NAME)


def test_registered_kind_is_in_the_plant_file(drag, tmp_path):
    pe = PlantEffects(["q2", "q3", "q4"], [Effect("quadratic_drag", "q3", {"c_nm_s2_rad2": 0.5})])
    pe.save(tmp_path / "p.json")
    back = PlantEffects.load(tmp_path / "p.json")
    assert kind("quadratic_drag") is drag
    np.testing.assert_allclose(back.friction_torque(np.array([0.0, -2.0, 0.0])), [0.0, 2.0, 0.0])


def test_made_up_effect_synth_identify_select_report(drag, tmp_path):
    rep, hidden = run_case(tmp_path, ["quadratic_drag:joint=q3"], 11, plots=True)
    errs = check_named(rep, hidden)
    assert not errs, errs
    md = (tmp_path / "out" / "report.md").read_text()
    assert "| quadratic_drag | q3 | c_nm_s2_rad2=" in md
    assert (tmp_path / "out" / "overlay_replay.png").stat().st_size > 0
