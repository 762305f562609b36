"""A URDF whose last link is massless (a tool flange): named in a warning at load, inverse dynamics runs,
replay uses the identified rotor inertia or names the joint it cannot replay; a singular mass matrix is a
numerical failure, not bad input."""

from __future__ import annotations

import logging

import numpy as np
import pytest

from sparc_quad.effects import PlantEffects
from sparc_quad.gap.errors import NumericalError
from sparc_quad.gap.robot import Robot
from sparc_quad.gap.synth import synth
from sparc_quad.gap.workflow import run
from tests.integration.gap.test_gap_workflow import CHAIN

FLANGE = CHAIN.replace("</robot>", """  <joint name="flange" type="revolute">
    <parent link="fore"/><child link="tool"/>
    <origin xyz="0 0.16 0"/><axis xyz="0 1 0"/>
    <limit lower="-3" upper="3" effort="2" velocity="20"/></joint>
  <link name="tool"/>
</robot>
""")


@pytest.fixture
def urdf(tmp_path):
    p = tmp_path / "flange.urdf"
    p.write_text(FLANGE)
    return p


def test_massless_link_warned_by_name(urdf, caplog):
    with caplog.at_level(logging.WARNING):
        rb = Robot(urdf, ["shoulder", "elbow", "flange"], {"mount": 0.3})
    assert rb.singular_joints == ["flange"]
    assert "'flange'" in caplog.text and "'tool'" in caplog.text
    assert rb.massless_joints(np.array([0.0, 0.0, 1e-4])) == []
    q = np.zeros((1, 3))
    with pytest.raises(np.linalg.LinAlgError):  # what replay would hit without the prescription
        import pinocchio as pin
        data = rb.model.createData()
        np.linalg.solve(pin.crba(rb.model, data, q[0]), np.ones(3))


def test_flange_rotor_inertia_named_and_replayed(urdf, tmp_path):
    act = ["shoulder", "elbow", "flange"]
    # the flange's rotor inertia is all it moves: 2e-3 kg m^2 against 5 mN m of torque noise
    res = synth(tmp_path / "trials", ["rotor_inertia:joint=flange,inertia_kg_m2=2e-3"], seed=4, n_trials=3,
                periods=3, period_s=1.5, amp_rad=0.4, urdf=urdf, actuated=act, fixed={"mount": 0.3},
                nominal=PlantEffects(act), torque_noise_nm=0.005)
    rep = run(res["trials"], tmp_path / "out", plots=True)
    assert rep["model_checks"]["massless_joints"] == ["flange"]
    assert rep["model_checks"]["not_replayed_nominal"] == ["flange"]  # nothing to integrate it with
    assert rep["gap_before"]["replay_rms_rad"]["flange"] is None
    assert [(e["name"], e["joint"]) for e in rep["effects"]] == [("rotor_inertia", "flange")], rep["effects"]
    assert rep["model_checks"]["not_replayed_final"] == []  # the identified rotor inertia makes it replayable
    assert rep["gap_after"]["replay_rms_rad"]["flange"] is not None
    assert "not replayed" in (tmp_path / "out" / "report.md").read_text()


def test_singular_replay_is_a_numerical_failure(urdf, tmp_path, monkeypatch, capsys):
    from sparc_quad.cli import main
    from sparc_quad.gap import robot as R

    act = ["shoulder", "elbow", "flange"]
    res = synth(tmp_path / "trials", ["rotor_inertia:joint=flange,inertia_kg_m2=2e-4"], seed=5, n_trials=2,
                periods=2, period_s=1.0, amp_rad=0.4, urdf=urdf, actuated=act, fixed={"mount": 0.3},
                nominal=PlantEffects(act))
    monkeypatch.setattr(R.Robot, "massless_joints", lambda self, armature=None: [])  # check bypassed
    with pytest.raises(NumericalError, match="replay"):
        run(res["trials"], tmp_path / "out", plots=False)
    rc = main(["gap", "run", *map(str, res["trials"]), "--out", str(tmp_path / "out2"), "--no-plots"])
    assert rc == 1
    assert "numerical failure (not bad input)" in capsys.readouterr().err
