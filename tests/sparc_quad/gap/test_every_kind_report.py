"""The whole workflow with plots and the report written on a case that names every effect kind the
library has (the registry is iterated, so a new kind is covered without editing this test): each kind's
term is fitted on the data, written to plant.json, replayed, formatted in report.md."""

from __future__ import annotations

import json

import numpy as np

from sparc_quad.effects import EFFECTS, PlantEffects
from sparc_quad.gap import select as S
from sparc_quad.gap import workflow
from sparc_quad.gap.synth import synth


def name_every_kind(sel, max_effects=None, torque_kind="commanded", couplings=()):
    """In place of the stepwise search: one term of every registered kind, each fitted alone (next to what
    it refines), with a motor coupling q3 + q4 for the coupled kinds."""
    search = S.Search(sel, torque_kind, [("q4", np.array([0.0, 1.0, 1.0]))])
    joint = sel.robot.actuated[1]
    singles = [sel.candidate([], k.NAME, joint)[0] for k in EFFECTS.values() if k.SINGLE]
    for t in singles:
        search.assign([t])
    taken = {t.key for t in singles}
    options = [t for k in EFFECTS.values()
               for opt in k.joint_options(search, singles, taken, joint) + k.options(search, singles, taken)
               for t in opt]
    chosen = {t.name: t for t in singles}
    for t in options:
        if t.name not in chosen:
            search.assign([*(s for s in singles if s.name == t.kind.REFINES), t])
            chosen[t.name] = t
    selected = [chosen[name] for name in EFFECTS]
    steps = [S.StepRecord(t, -100.0, 10.0, []) for t in selected]
    return steps, sel.fit(selected), [{"step": 1, "top": []}]


def test_every_kind_named_and_reported(tmp_path, monkeypatch):
    res = synth(tmp_path / "trials", ["coulomb_friction:joint=q3"], seed=3, n_trials=2, periods=2,
                period_s=1.5, amp_rad=0.4)
    monkeypatch.setattr(workflow.S, "select", name_every_kind)
    rep = workflow.run(res["trials"], tmp_path / "out", plots=True)
    out = tmp_path / "out"
    assert [e["name"] for e in rep["effects"]] == list(EFFECTS)
    assert json.loads((out / "report.json").read_text())["effects"] == json.loads(json.dumps(rep["effects"]))
    plant = PlantEffects.load(out / "plant.json")
    assert [e.name for e in plant.effects][-len(EFFECTS):] == list(EFFECTS)
    md = (out / "report.md").read_text()
    for e in rep["effects"]:
        assert f"| {e['name']} | {e['joint']} | {EFFECTS[e['name']].format_params(e['params'])} |" in md
    assert "combination=" in md  # the string parameter of link_inertia, formatted as text
    for png in ("residual_by_regime", "residual_time", "overlay_residual", "overlay_replay"):
        assert (out / f"{png}.png").stat().st_size > 0
