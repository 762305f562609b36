"""Every listed host bounds with its own defaults in both engines, and a host the project has never seen
bounds from a host file written by a user (here: Go1's, copied into a temporary folder)."""

from __future__ import annotations

import json
import shutil

import pytest

from sparc_quad import Scenario, run_bound
from sparc_quad.cli import main
from sparc_quad.robots import ROBOTS_DIR
from sparc_quad.sim.hosts import HOSTS

pytestmark = pytest.mark.filterwarnings("ignore:steady window")


@pytest.mark.parametrize("engine", ["pybullet", "mujoco"])
@pytest.mark.parametrize("host", HOSTS)
def test_every_listed_host_bounds_with_its_defaults(host, engine):
    pytest.importorskip(engine)
    m = run_bound(Scenario(host=host, engine=engine, duration=10.0)).metrics
    assert not m["fell"], (host, engine, m["fall_time_s"], m["fall_reason"])
    assert m["speed_m_s"] > 0.3  # it bounds forward, near the speed its defaults command (0.4-0.6 m/s)


def test_a_users_host_file_bounds_outside_robots(tmp_path, monkeypatch):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    mine = tmp_path / "my_robot"
    mine.mkdir()
    shutil.copy(ROBOTS_DIR / "sparc_go1" / "host.toml", mine / "host.toml")
    out = tmp_path / "out"
    assert main(["robots", "check", str(mine / "host.toml")]) == 0
    assert main(["bound", "--host-file", str(mine / "host.toml"), "--duration", "2", "--no-plots", "--out",
                 str(out)]) == 0
    doc = json.loads((out / "scenario.json").read_text())
    assert doc["scenario"]["host_file"] == str(mine / "host.toml") and doc["scenario"]["height"] == 0.28
    assert list((tmp_path / "cache" / "sparc-quad" / "hosts").glob("go1-*/sparc_go1.urdf"))


def test_cot_elec_only_where_the_leg_actuators_are_known():
    """CoT_elec needs the legs' winding losses: Solo12's are documented (spine_module.params), the other
    hosts' are not, so it is not defined there (it was computed with Solo12's constants on every host)."""
    solo = run_bound(Scenario(host="solo12", duration=2.0)).metrics
    a1 = run_bound(Scenario(host="a1", duration=2.0)).metrics
    assert solo["cot_elec_total"] > solo["cot_pos_total"] > 0  # winding losses add to the positive work
    assert a1["cot_pos_total"] > 0 and a1["cot_elec_total"] != a1["cot_elec_total"]  # NaN
