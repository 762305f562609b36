"""robots/spined_dog: the generated MJCF and URDF carry the parameter table, and the table is the authors'
model (their MJCF parsed by MuJoCo, when the snapshot of their repository is on this machine)."""

from __future__ import annotations

import subprocess
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

from sparc_quad.robots import ROBOTS_DIR
from sparc_quad.sim import spined_dog as D
from sparc_quad.sim.hosts import host_files
from sparc_quad.sim.robot_files import generate_all

AUTHORS_MJCF = "mujoco_simulation/asset/spined_dog.xml"


def _ours():
    mujoco = pytest.importorskip("mujoco")
    return mujoco, mujoco.MjModel.from_xml_path(str(host_files(D.HOST).mjcf))


def _authors(repo: Path):
    """The authors' MJCF compiled without its (visual-only) meshes, whose files are not all present."""
    mujoco = pytest.importorskip("mujoco")
    res = subprocess.run(["git", "-C", str(repo), "show", f"{D.SOURCE_COMMIT}:{AUTHORS_MJCF}"],
                         capture_output=True, text=True)
    if res.returncode != 0:
        pytest.fail(f"{repo} lacks {AUTHORS_MJCF} at commit {D.SOURCE_COMMIT[:7]}: fetch their full history")
    spec = mujoco.MjSpec.from_string(res.stdout)
    for g in list(spec.geoms):
        if g.type == mujoco.mjtGeom.mjGEOM_MESH:
            spec.delete(g)
    for m in list(spec.meshes):
        spec.delete(m)
    return spec.compile()


def test_generated_files_are_registered_and_committed():
    files = generate_all()
    d = ROBOTS_DIR / "spined_dog"
    for name in ("spined_dog.xml", "spined_dog.urdf", "spined_dog.json", "README.md"):
        assert files[d / name] == (d / name).read_text(), f"{name} drifted: run `sparc-quad robots generate`"


def test_mjcf_carries_the_table():
    mujoco, m = _ours()
    assert m.nbody - 1 == len(D.BODIES)
    for b in D.BODIES:
        i = m.body(b.name).id
        assert m.body_mass[i] == pytest.approx(b.mass_kg, abs=1e-12)
        np.testing.assert_allclose(m.body_inertia[i], b.inertia_kg_m2, atol=1e-15)
        np.testing.assert_allclose(m.body_ipos[i], b.com_m, atol=1e-12)
        np.testing.assert_allclose(m.body_pos[i], b.pos_m, atol=1e-12)
        if b.joint is not None:
            j = m.joint(b.joint).id
            assert m.jnt_bodyid[j] == i
            np.testing.assert_array_equal(m.jnt_axis[j], [0, 1, 0])
            np.testing.assert_array_equal(m.jnt_actfrcrange[j], [-D.MOTOR_LIMIT_NM, D.MOTOR_LIMIT_NM])
    assert float(m.body_mass.sum()) == pytest.approx(D.TOTAL_MASS_KG) == pytest.approx(5.792036)
    assert m.nu == 11 and (m.actuator_ctrlrange == [-12.0, 12.0]).all()
    o = m.opt
    assert (o.timestep, o.iterations, o.tolerance, o.noslip_iterations) == (1e-3, 1000, 1e-8, 2)
    assert o.solver == mujoco.mjtSolver.mjSOL_CG and o.cone == mujoco.mjtCone.mjCONE_ELLIPTIC


def test_only_the_four_foot_spheres_collide_in_both_files():
    mujoco, m = _ours()
    colliding = [g for g in range(m.ngeom) if m.geom_contype[g] or m.geom_conaffinity[g]]
    floor = m.geom("floor").id
    feet = sorted(m.body(m.geom_bodyid[g]).name for g in colliding if g != floor)
    assert feet == sorted(f"{p}_foot" for p in ("hind_left", "hind_right", "front_left", "front_right"))
    for g in colliding:
        if g != floor:
            assert m.geom_type[g] == mujoco.mjtGeom.mjGEOM_SPHERE and m.geom_size[g][0] == D.FOOT_RADIUS_M
    np.testing.assert_allclose(m.geom_friction[floor], D.PHYSICS.floor_friction)
    urdf = ET.parse(host_files(D.HOST).urdf).getroot()
    shapes = [(link.get("name"), [c.tag for c in col.find("geometry")])
              for link in urdf.findall("link") for col in link.findall("collision")]
    assert sorted(n for n, _ in shapes) == feet and all(s == ["sphere"] for _, s in shapes)


def test_urdf_carries_the_table():
    model = pin.buildModelFromUrdf(str(host_files(D.HOST).urdf), pin.JointModelFreeFlyer())
    data = model.createData()
    assert pin.computeTotalMass(model, data) == pytest.approx(D.TOTAL_MASS_KG)
    assert sorted(model.names[2:]) == sorted(D.hinge_joints())
    for name in D.hinge_joints():
        assert model.joints[model.getJointId(name)].shortname() == "JointModelRY"
    assert list(model.effortLimit[6:]) == [D.MOTOR_LIMIT_NM] * 11


@pytest.mark.reproduction
def test_table_matches_the_authors_mjcf(authors_repo):
    _, ours = _ours()
    theirs = _authors(authors_repo)
    assert ours.nbody == theirs.nbody and ours.njnt == theirs.njnt and ours.nu == theirs.nu
    for i in range(1, ours.nbody):
        j = theirs.body(ours.body(i).name).id
        assert ours.body_mass[i] == pytest.approx(theirs.body_mass[j], abs=1e-12)
        np.testing.assert_allclose(ours.body_inertia[i], theirs.body_inertia[j], atol=1e-15)
        np.testing.assert_allclose(ours.body_pos[i], theirs.body_pos[j], atol=1e-12)
        np.testing.assert_allclose(ours.body_ipos[i], theirs.body_ipos[j], atol=1e-12)
    for j in range(1, ours.njnt):  # the hinges (joint 0 is the free joint)
        k = theirs.joint(ours.joint(j).name).id
        np.testing.assert_array_equal(ours.jnt_axis[j], theirs.jnt_axis[k])
        np.testing.assert_array_equal(ours.jnt_range[j], theirs.jnt_range[k])
        np.testing.assert_array_equal(ours.jnt_actfrcrange[j], theirs.jnt_actfrcrange[k])
    for name in ("timestep", "iterations", "tolerance", "noslip_iterations", "solver", "cone", "impratio"):
        assert getattr(ours.opt, name) == getattr(theirs.opt, name), name
    np.testing.assert_allclose(ours.geom_friction[ours.geom("floor").id], theirs.geom_friction[0])


def test_spine_offset_is_the_lever_difference():
    """The SPARC model's task x exceeds the dog's front-body x by the lever difference when theta = 0."""
    from spine_module.model import SpineModel

    model = SpineModel()
    data = model.create_data()
    for a in (0.6, 0.785, 0.9):
        q = np.array([0.0, -a, 2 * a, -a])
        model.update_kinematics(data, q, np.zeros(4))
        x_dog, _, th = D.dog_spine_x(*q[1:])
        assert data.x[0] - x_dog == pytest.approx(D.SPINE_X_OFFSET_M, abs=1e-12)
        assert th == pytest.approx(data.x[2], abs=1e-12)
