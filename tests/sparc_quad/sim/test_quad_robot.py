"""The spined quadruped generator: committed files match, masses add up, a second host works."""

from __future__ import annotations

import json

import pybullet as pb
import pytest

from sparc_quad.robots import ROBOTS_DIR
from sparc_quad.sim import hosts
from sparc_quad.sim import quadruped_urdf as Q
from sparc_quad.sim.hosts import host_files, host_of, listed_hosts
from spine_module import params as P

SPLICED = [h for h, f in listed_hosts().items() if f.generator == "splice"]


@pytest.mark.parametrize("host", SPLICED)
def test_committed_files_match_the_generator(host):
    files = hosts.generate(ROBOTS_DIR)
    for path in Q.robot_paths(ROBOTS_DIR / f"sparc_{host}", host):
        assert path.read_text() == files[path], f"{path} drifted: run `sparc-quad robots generate`"


def test_host_found_in_installed_example_robot_data():
    path = host_of("solo12").urdf_path()
    assert path.exists() and path.name == "solo12.urdf"


@pytest.mark.parametrize("host", SPLICED)
def test_loads_in_pybullet_with_expected_joints_and_mass(host):
    urdf, meta_path = host_files(host).urdf, host_files(host).meta
    meta = json.loads(meta_path.read_text())
    c = pb.connect(pb.DIRECT)
    try:
        body = pb.loadURDF(str(urdf), flags=pb.URDF_USE_INERTIA_FROM_FILE, physicsClientId=c)
        n = pb.getNumJoints(body, physicsClientId=c)
        revolute = [pb.getJointInfo(body, i, physicsClientId=c)[1].decode() for i in range(n)
                    if pb.getJointInfo(body, i, physicsClientId=c)[2] == pb.JOINT_REVOLUTE]
        mass = sum(pb.getDynamicsInfo(body, i, physicsClientId=c)[0] for i in range(-1, n))
    finally:
        pb.disconnect(c)
    assert len(revolute) == 15  # 3 spine + 4 x 3 legs
    assert {"q2", "q3", "q4"} <= set(revolute)
    assert mass == pytest.approx(meta["mass_kg"]["total"], abs=0.01)
    groups = meta["mass_kg"]
    parts = groups["hind_group"] + groups["spine_middle"] + groups["front_group"]
    assert parts == pytest.approx(groups["total"])
    assert groups["spine_middle"] == pytest.approx(P.HIND_SPINE.mass_kg + P.FRONT_SPINE.mass_kg)


def test_hip_spacing_equals_host_at_equilibrium():
    meta = Q.quadruped(host_of("solo12")).meta
    front = meta["legs"]["FL"]["hip_x_m"] + P.X_EQUILIBRIUM[0] - meta["front_body_length_m"]
    assert front - meta["legs"]["HL"]["hip_x_m"] == pytest.approx(0.3892, abs=1e-6)  # Solo12: 2 x 0.1946
    assert meta["q_equilibrium"] == pytest.approx(list(P.Q_EQUILIBRIUM))


def test_second_host_stands_in_the_world():
    from sparc_quad.bound.run import BoundConfig, run_bound
    from sparc_quad.gaits.bound import BoundParams
    from sparc_quad.sim.quadruped_world import WorldConfig

    cfg = BoundConfig(duration_s=1.0, world=WorldConfig(host="a1"), gait=BoundParams(start_s=10.0),
                      spine_variant="rigid", settle_s=0.0)
    r = run_bound(cfg)
    assert not r.metrics["fell"]
    assert r.column("z")[-1] == pytest.approx(0.22 + 0.02, abs=0.04)  # hips near the stand height
