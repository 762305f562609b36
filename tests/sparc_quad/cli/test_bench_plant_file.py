"""`--plant FILE` takes a PlantConfig JSON or a gap workflow plant.json, and the bench obeys it."""

import json

import numpy as np
import pytest

from sparc_quad.cli import main
from sparc_quad.effects import Effect, PlantEffects
from sparc_quad.sim.bench_world import BenchWorld
from sparc_quad.sim.plant import PlantConfig
from spine_module import params as P


def gain_file(tmp_path, gain: float):
    pe = PlantEffects(list(P.ACTUATED_JOINTS), [Effect("torque_gain", "q3", {"gain": gain})])
    path = tmp_path / "plant.json"
    pe.save(path)
    return path


def test_plant_config_round_trips_through_json(tmp_path):
    cfg = PlantConfig().with_friction_factors(coulomb=2.0)
    path = tmp_path / "cfg.json"
    path.write_text(json.dumps(cfg.to_json()))
    assert PlantConfig.load(path) == cfg


def test_gap_plant_file_is_nominal_model_plus_effects(tmp_path):
    cfg = PlantConfig.load(gain_file(tmp_path, 0.5))
    assert cfg.friction == P.NOMINAL_FRICTION
    with BenchWorld(plant=cfg) as w:
        w.step(np.array([0.2, 0.2, 0.2]))
        np.testing.assert_allclose(w.last_applied, [0.2, 0.1, 0.2])


def test_bad_plant_file_names_the_file(tmp_path):
    bad = tmp_path / "bad.json"
    bad.write_text('{"frictoin": {}}')
    with pytest.raises(ValueError, match=r"bad\.json"):
        PlantConfig.load(bad)


def test_bench_cli_runs_with_a_gap_plant_file(tmp_path):
    out = tmp_path / "out"
    assert main(["bench", "static", "--quick", "--kx", "500", "--plant", str(gain_file(tmp_path, 0.7)),
                 "--out", str(out)]) == 0
    doc = json.loads((out / "static.json").read_text())
    assert doc["plant"]["effects"]["effects"][0]["name"] == "torque_gain"
    # a 30 % weaker q3 actuator (which carries x at the equilibrium) softens the rendered spring
    assert doc["rows"][0]["k_hat"] < 450
