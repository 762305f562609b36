"""Host files: the listed hosts are host.toml files; a bad one is refused with every problem named, one
line each (`sparc-quad robots check`)."""

from __future__ import annotations

import pytest

from sparc_quad.cli import main
from sparc_quad.robots import ROBOTS_DIR
from sparc_quad.scenario import Scenario, ScenarioError, resolved
from sparc_quad.scenario.hosts import check_host
from sparc_quad.sim.host_file import HostFileError, load_host_file
from sparc_quad.sim.hosts import HOSTS, listed_hosts

GOOD = """name = "mine"
[model]
example_robot_data = "robots/a1_description/urdf/a1.urdf"
[legs]
knee_sign_front = -1
knee_sign_hind = -1
foot_radius_m = 0.02
torque_limit_nm = 33.5
velocity_limit_rad_s = 21.0
"""


def test_the_listed_hosts_are_their_host_files():
    assert HOSTS[:3] == ("solo12", "a1", "spined-dog") and {"go1", "go2"} <= set(HOSTS)
    for host in listed_hosts().values():
        assert host.path == ROBOTS_DIR / host.path.parent.name / "host.toml" and check_host(host.path) == []
    assert resolved(Scenario(host="a1")).frequency == 3.0  # its file's [defaults.raibert]
    assert resolved(Scenario(host="solo12")).frequency == 4.0  # the gait's own
    assert resolved(Scenario(host="spined-dog", gait="sine")).step_length == 0.08


def write(tmp_path, text: str):
    path = tmp_path / "host.toml"
    path.write_text(text)
    return path


@pytest.mark.parametrize(("text", "problem"), [
    (GOOD.replace('name = "mine"', 'name = "Mine Robot"'), "name:"),
    (GOOD + "colour = 1\n", "colour: unknown key"),
    (GOOD.replace("foot_radius_m = 0.02\n", ""), "legs.foot_radius_m: missing"),
    (GOOD.replace("knee_sign_hind = -1", "knee_sign_hind = 2"), "legs.knee_sign_hind"),
    (GOOD.replace("torque_limit_nm = 33.5", "torque_limit_nm = -3"), "legs.torque_limit_nm"),
    (GOOD.replace('example_robot_data = "robots/a1_description/urdf/a1.urdf"', 'urdf = "nosuch.urdf"'),
     "model.urdf: no such file"),
    (GOOD + 'urdf = "x.urdf"\n', "legs.urdf: unknown key"),
])
def test_a_bad_host_file_names_each_problem(tmp_path, text, problem):
    path = write(tmp_path, text)
    with pytest.raises(HostFileError) as exc:
        load_host_file(path)
    assert any(problem in p for p in exc.value.problems), exc.value.problems
    assert any(problem in line for line in check_host(path))


def test_check_finds_what_the_urdf_and_the_pose_cannot_give(tmp_path, capsys):
    short = tmp_path / "short.urdf"
    src = load_host_file(write(tmp_path, GOOD)).urdf_path().read_text()
    short.write_text(src.replace('xyz="0 0 -0.2"', 'xyz="0 0 -0.05"'))  # shanks and thighs of 5 cm
    path = write(tmp_path, GOOD.replace('example_robot_data = "robots/a1_description/urdf/a1.urdf"',
                                        'urdf = "short.urdf"'))
    assert any("no standing pose" in p for p in check_host(path))
    three = tmp_path / "three.urdf"
    three.write_text(src.replace('name="FL_hip_joint" type="revolute"', 'name="FL_hip_joint" type="fixed"'))
    path = write(tmp_path, GOOD.replace('example_robot_data = "robots/a1_description/urdf/a1.urdf"',
                                        'urdf = "three.urdf"'))
    assert any("four legs" in p or "expected" in p for p in check_host(path))
    path = write(tmp_path, GOOD + '[model2]\n')
    assert main(["robots", "check", str(path)]) == 1
    assert "model2: unknown key" in capsys.readouterr().out
    path = write(tmp_path, GOOD + "[defaults.raibert]\nslope = 0.1\nfrequency = 99\n")
    problems = check_host(path)
    assert any("slope" in p for p in problems) and any("frequency" in p for p in problems)
    path = write(tmp_path, GOOD.replace("[model]\n", '[model]\ntrunk = "nope"\n'))
    assert any("trunk link 'nope'" in p for p in check_host(path))


def test_host_file_key_is_refused_beside_host(tmp_path):
    path = write(tmp_path, GOOD)
    with pytest.raises(ScenarioError, match="host_file"):
        Scenario(host="a1", host_file=str(path))
    assert resolved(Scenario(host_file=str(path))).host_file == str(path)
