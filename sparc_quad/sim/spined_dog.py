"""The SPARC authors' spined quadruped ("spined dog") as a parameter table, and the MJCF, URDF, metadata
and README generated from it into `robots/spined_dog/`.

Every number below is read from the authors' model (github.com/YueWang996/sparc, commit d9639f5,
`mujoco_simulation/asset/spined_dog.xml` and `spined_dog.urdf`; sha256 in `SOURCES`); MIT licence,
Copyright (c) 2026 YueWang996. Their files are not copied: the text is written here from the table.
What we changed: every mesh (visual only in their model) is a primitive shape sized from the body's
inertia or its joint-to-joint segment; the URDF gets the MJCF's 0.01 kg foot links (their URDF has
none), so both engines carry the same masses; only the four r = 0.03 m foot spheres collide, in both.

Layout (x forward, z up, every joint a hinge about +y):

    hind_body (floating base) -- hind legs (hip, knee), hind_spine -> front_spine -> front_body
    front_body -- front legs (hip, knee)

The authors' three spine joints are the project's q2, q3, q4; their hind body is q1's body. Their hind
body frame sits at its centre of mass, 0.1068 m behind the first spine joint, and the front body frame
at the last spine joint; the SPARC model the controller uses (spine_module/params.py) puts its q1 axis
0.0632 m behind q2 and its end effector 0.0632 m ahead of q4 (docs/bounding/robots.md, "The SPARC
controller on the dog's spine").
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path

from spine_module import params as P

HOST = "spined-dog"
NAME = "spined_dog"
SOURCE_URL = "https://github.com/YueWang996/sparc"
SOURCE_COMMIT = "d9639f5b62fe3a3c7ac8b7d4b30ceef9181dfc5c"
# sha256 of each authors' file the numbers come from (git show d9639f5:<path> | sha256sum)
SOURCES: dict[str, str] = {
    "mujoco_simulation/asset/spined_dog.xml":
        "75ac2f0460f40a8d8b024e8b73658a90c49057239d3beb5e87fbd9c11cc887d3",
    "mujoco_simulation/asset/spined_dog.urdf":
        "7561eb40b963a0e80cffc829048fce09906bc39a607221a27262edccfcbfd16d",
    "LICENSE": "6f6625eb67541eb24356156c00978daaeba46f7c8e168712d9adf1d486256f9c",
}
COPYRIGHT = "Copyright (c) 2026 YueWang996"

Vec = tuple[float, float, float]


@dataclass(frozen=True)
class Body:
    """One rigid body: its frame in the parent's (`pos_m`), the hinge about +y at its origin (None: the
    floating base, or a fixed foot), inertia about the centre of mass along the body axes."""

    name: str
    parent: str | None
    joint: str | None
    pos_m: Vec
    mass_kg: float
    com_m: Vec
    inertia_kg_m2: Vec  # (Ixx, Iyy, Izz)


@dataclass(frozen=True)
class Physics:
    """The authors' MJCF <option> and contact settings."""

    timestep_s: float = 1e-3
    iterations: int = 1000
    tolerance: float = 1e-8
    impratio: float = 1.0
    solver: str = "CG"
    cone: str = "elliptic"
    noslip_iterations: int = 2
    floor_friction: Vec = (1.0, 0.005, 0.0001)  # sliding, torsional, rolling
    gravity_m_s2: float = 9.81


PHYSICS = Physics()
JOINT_RANGE_RAD = 10.0  # every hinge: range -10..10 rad (effectively unlimited)
MOTOR_LIMIT_NM = 12.0  # every joint's torque motor: ctrlrange and actuatorfrcrange +-12 N*m
VELOCITY_LIMIT_RAD_S = 100.0  # their URDF's <limit velocity>
FOOT_RADIUS_M = 0.03  # collision sphere (their visual sphere is 0.028 m)
BASE_HEIGHT_M = 0.24  # hind_body's initial height in their MJCF
THIGH_M = 0.151
SHANK_M = 0.151  # knee to foot centre
_UPPER_I: Vec = (0.000873, 0.000942, 0.000192)
_LOWER_I: Vec = (0.000223, 0.000225, 0.000005078)
_FOOT_I: Vec = (1e-5, 1e-5, 1e-5)
_BODY_I: Vec = (0.01614, 0.007591, 0.02169)
UPPER_KG, LOWER_KG, FOOT_KG, BODY_KG = 0.252259, 0.051, 0.01, 2.044

# Legs: key -> (prefix, parent body, hip position in the parent, thigh COM, knee offset y, shank COM)
_LEGS: dict[str, tuple[str, str, Vec, Vec, float, Vec]] = {
    "HL": ("hind_left", "hind_body", (-0.032496964, 0.137389577, -0.00028757),
           (0.000884, 0.011774, -0.058206), 0.012, (0.000327, 0.0, -0.061393)),
    "HR": ("hind_right", "hind_body", (-0.032496964, -0.136610423, -0.00028757),
           (0.000883, -0.011774, -0.058205), -0.012, (0.000327, 0.0, -0.061393)),
    "FL": ("front_left", "front_body", (0.139742934, 0.11725, -0.00245609),
           (-0.000883, 0.011774, -0.058205), 0.012, (-0.000327, 0.0, -0.061393)),
    "FR": ("front_right", "front_body", (0.139742934, -0.15675, -0.002456609),
           (-0.000884, -0.011774, -0.058206), -0.012, (-0.000327, 0.0, -0.061393)),
}
LEG_KEYS = ("HL", "HR", "FL", "FR")
# knee sign of the standing pose: the authors' q0 (hind knees +pi/2, front knees -pi/2)
KNEE_SIGN = {"HL": 1, "HR": 1, "FL": -1, "FR": -1}
SPINE_JOINTS = ("joint_hind_spine", "joint_front_spine", "joint_front_body")


def _leg_bodies(key: str) -> list[Body]:
    prefix, parent, hip, thigh_com, knee_y, shank_com = _LEGS[key]
    return [
        Body(f"{prefix}_leg_upper", parent, f"joint_{prefix}_leg_upper", hip, UPPER_KG, thigh_com, _UPPER_I),
        Body(f"{prefix}_leg_lower", f"{prefix}_leg_upper", f"joint_{prefix}_leg_lower",
             (0.0, knee_y, -THIGH_M), LOWER_KG, shank_com, _LOWER_I),
        Body(f"{prefix}_foot", f"{prefix}_leg_lower", None, (0.0, 0.0, -SHANK_M), FOOT_KG, (0.0, 0.0, 0.0),
             _FOOT_I),
    ]


BODIES: tuple[Body, ...] = (
    Body("hind_body", None, None, (0.0, 0.0, BASE_HEIGHT_M), BODY_KG, (0.0, 0.0, 0.0), _BODY_I),
    *_leg_bodies("HL"), *_leg_bodies("HR"),
    Body("hind_spine", "hind_body", "joint_hind_spine", (0.106797362, -0.019360423, 0.000984733), 0.399,
         (0.109455866, 0.014797864, 0.0), (0.0001953, 0.0005357, 0.0004759)),
    Body("front_spine", "hind_spine", "joint_front_spine", (0.1175, 0.036, 0.0), 0.052,
         (0.05875, 0.0073, 0.0), (0.0000036976, 0.000084358, 0.000082312887603)),
    Body("front_body", "front_spine", "joint_front_body", (0.1175, 0.0, 0.0), BODY_KG,
         (0.107249862, -0.019360422, -0.002160635), _BODY_I),
    *_leg_bodies("FL"), *_leg_bodies("FR"),
)
BY_NAME = {b.name: b for b in BODIES}
TOTAL_MASS_KG = sum(b.mass_kg for b in BODIES)


def children(name: str) -> list[Body]:
    return [b for b in BODIES if b.parent == name]


def hinge_joints() -> list[str]:
    """Every actuated joint, in the order of the bodies (depth first)."""
    return [b.joint for b in BODIES if b.joint is not None]


# --- the spine seen by the project's SPARC model ------------------------------------------------------
HIND_LEVER_M = BY_NAME["hind_spine"].pos_m[0]  # hind_body frame -> first spine joint, along x
SPINE_SEGMENTS_M = (BY_NAME["front_spine"].pos_m[0], BY_NAME["front_body"].pos_m[0])
# Task x of the SPARC model minus the dog's front-body-frame x (both in the hind-body frame) when the
# front body is parallel to the hind body (theta = 0): the model's hind link and front link are 0.0632 m
# each, the dog's levers 0.1068 m and 0.
SPINE_X_OFFSET_M = P.HIND_BODY.length_m + P.FRONT_BODY.length_m - HIND_LEVER_M


def dog_spine_x(q2: float, q3: float, q4: float) -> tuple[float, float, float]:
    """(x, z, theta) of the dog's front body frame in its hind body frame (the authors' task space)."""
    hx, _, hz = BY_NAME["hind_spine"].pos_m
    a, b = SPINE_SEGMENTS_M
    x = hx + a * math.cos(q2) + b * math.cos(q2 + q3)
    z = hz - a * math.sin(q2) - b * math.sin(q2 + q3)
    return x, z, q2 + q3 + q4


# --- text --------------------------------------------------------------------------------------------
def _f(v: float) -> str:
    s = f"{v:.12g}"
    return "0" if s in ("-0", "0") else s


def _v(v) -> str:
    return " ".join(_f(x) for x in v)


def _box_from_inertia(mass: float, inertia: Vec) -> Vec:
    """Dimensions of the uniform box with these principal moments (a visual stand-in for a mesh)."""
    ixx, iyy, izz = inertia
    dims = (6 * (iyy + izz - ixx) / mass, 6 * (ixx + izz - iyy) / mass, 6 * (ixx + iyy - izz) / mass)
    return tuple(math.sqrt(max(d, 1e-4)) for d in dims)  # type: ignore[return-value]


def _segment(body: Body) -> Vec | None:
    """The segment a leg or spine link's visual capsule spans: origin -> its (first) child's origin."""
    kids = children(body.name)
    return kids[0].pos_m if kids and body.name not in ("hind_body", "front_body") else None


def _fromto(vec: Vec) -> str:
    return f"0 0 0 {_v(vec)}"


HEADER = (
    "Generated by sparc_quad/sim/spined_dog.py (sparc-quad robots generate); do not edit by hand. SI units.\n"
    f"The SPARC authors' spined dog: numbers from {SOURCE_URL} commit {SOURCE_COMMIT[:7]},\n"
    "mujoco_simulation/asset/spined_dog.xml and spined_dog.urdf (MIT licence, "
    f"{COPYRIGHT}).\n"
    "Visual shapes are primitives (their meshes are visual only); only the foot spheres collide.\n"
)


def mjcf() -> str:
    ph = PHYSICS
    out = ['<?xml version="1.0"?>\n', f"<!--\n{HEADER}-->\n", f'<mujoco model="{NAME}">\n',
           '  <compiler angle="radian" balanceinertia="true" autolimits="true"/>\n',
           f'  <option timestep="{_f(ph.timestep_s)}" iterations="{ph.iterations}" '
           f'tolerance="{_f(ph.tolerance)}" impratio="{_f(ph.impratio)}" gravity="0 0 {_f(-ph.gravity_m_s2)}"'
           f' solver="{ph.solver}" cone="{ph.cone}" noslip_iterations="{ph.noslip_iterations}"/>\n',
           "  <default>\n    <default class=\"dog\">\n",
           f'      <joint type="hinge" axis="0 1 0" range="{_f(-JOINT_RANGE_RAD)} {_f(JOINT_RANGE_RAD)}" '
           f'actuatorfrcrange="{_f(-MOTOR_LIMIT_NM)} {_f(MOTOR_LIMIT_NM)}" damping="0" frictionloss="0"/>\n',
           f'      <motor ctrlrange="{_f(-MOTOR_LIMIT_NM)} {_f(MOTOR_LIMIT_NM)}" gear="1"/>\n',
           '      <default class="visual">\n'
           '        <geom contype="0" conaffinity="0" group="1" density="0" rgba="0.7 0.7 0.7 1"/>\n'
           "      </default>\n",
           '      <default class="foot">\n'
           f'        <geom type="sphere" size="{_f(FOOT_RADIUS_M)}" contype="2" conaffinity="1" group="3"'
           ' rgba="0.1 0.1 0.1 1"/>\n      </default>\n',
           "    </default>\n  </default>\n",
           "  <worldbody>\n",
           f'    <geom name="floor" type="plane" size="30 30 0.1" contype="1" conaffinity="1" priority="1" '
           f'friction="{_v(ph.floor_friction)}" rgba="0.2 0.3 0.4 1"/>\n',
           '    <light directional="true" pos="0 0 4" dir="0 0 -1"/>\n']

    def body_xml(b: Body, depth: int) -> None:
        ind = "  " * depth
        cls = ' childclass="dog"' if b.parent is None else ""
        out.append(f'{ind}<body name="{b.name}" pos="{_v(b.pos_m)}"{cls}>\n')
        if b.parent is None:
            out.append(f'{ind}  <freejoint name="root"/>\n')
        out.append(f'{ind}  <inertial pos="{_v(b.com_m)}" mass="{_f(b.mass_kg)}" '
                   f'diaginertia="{_v(b.inertia_kg_m2)}"/>\n')
        if b.joint is not None:
            out.append(f'{ind}  <joint name="{b.joint}"/>\n')
        seg = _segment(b)
        if b.name.endswith("_foot"):
            out.append(f'{ind}  <geom name="{b.name}" class="foot"/>\n')
        elif seg is not None:
            out.append(f'{ind}  <geom class="visual" type="capsule" size="0.012" fromto="{_fromto(seg)}"/>\n')
        else:
            out.append(f'{ind}  <geom class="visual" type="box" pos="{_v(b.com_m)}" '
                       f'size="{_v(0.5 * d for d in _box_from_inertia(b.mass_kg, b.inertia_kg_m2))}"/>\n')
        for c in children(b.name):
            body_xml(c, depth + 1)
        out.append(f"{ind}</body>\n")

    body_xml(BODIES[0], 2)
    out.append("  </worldbody>\n  <actuator>\n")
    for j in hinge_joints():
        out.append(f'    <motor class="dog" name="{j.replace("joint_", "motor_", 1)}" joint="{j}"/>\n')
    out.append("  </actuator>\n</mujoco>\n")
    return "".join(out)


def urdf() -> str:
    out = ['<?xml version="1.0"?>\n', f"<!--\n{HEADER}-->\n", f'<robot name="{NAME}">\n',
           '  <material name="grey"><color rgba="0.7 0.7 0.7 1"/></material>\n',
           '  <material name="foot"><color rgba="0.1 0.1 0.1 1"/></material>\n']
    for b in BODIES:
        if b.parent is not None:
            jtype = "revolute" if b.joint is not None else "fixed"
            jname = b.joint or f"{b.name}_fixed"
            out.append(f'  <joint name="{jname}" type="{jtype}">\n    <parent link="{b.parent}"/>\n'
                       f'    <child link="{b.name}"/>\n    <origin xyz="{_v(b.pos_m)}" rpy="0 0 0"/>\n')
            if b.joint is not None:
                out.append(f'    <axis xyz="0 1 0"/>\n    <limit lower="{_f(-JOINT_RANGE_RAD)}" '
                           f'upper="{_f(JOINT_RANGE_RAD)}" effort="{_f(MOTOR_LIMIT_NM)}" '
                           f'velocity="{_f(VELOCITY_LIMIT_RAD_S)}"/>\n'
                           '    <dynamics damping="0" friction="0"/>\n')
            out.append("  </joint>\n")
        ixx, iyy, izz = b.inertia_kg_m2
        out.append(f'  <link name="{b.name}">\n    <inertial>\n'
                   f'      <origin xyz="{_v(b.com_m)}" rpy="0 0 0"/>\n      <mass value="{_f(b.mass_kg)}"/>\n'
                   f'      <inertia ixx="{_f(ixx)}" ixy="0" ixz="0" iyy="{_f(iyy)}" iyz="0"'
                   f' izz="{_f(izz)}"/>\n'
                   "    </inertial>\n")
        seg = _segment(b)
        if b.name.endswith("_foot"):
            sphere = f'<sphere radius="{_f(FOOT_RADIUS_M)}"/>'
            out.append(f'    <visual>\n      <geometry>{sphere}</geometry>\n      <material name="foot"/>\n'
                       f'    </visual>\n    <collision>\n      <geometry>{sphere}</geometry>\n'
                       "    </collision>\n")
        elif seg is not None:
            length = math.sqrt(sum(c * c for c in seg))
            ux, uy, uz = (c / length for c in seg)
            rpy = (-math.asin(max(-1.0, min(1.0, uy))), math.atan2(ux, uz), 0.0)
            out.append(f'    <visual>\n      <origin xyz="{_v(0.5 * c for c in seg)}" rpy="{_v(rpy)}"/>\n'
                       f'      <geometry><cylinder radius="0.012" length="{_f(length)}"/></geometry>\n'
                       '      <material name="grey"/>\n    </visual>\n')
        else:
            box = _box_from_inertia(b.mass_kg, b.inertia_kg_m2)
            out.append(f'    <visual>\n      <origin xyz="{_v(b.com_m)}" rpy="0 0 0"/>\n'
                       f'      <geometry><box size="{_v(box)}"/></geometry>\n'
                       '      <material name="grey"/>\n    </visual>\n')
        out.append("  </link>\n")
    out.append("</robot>\n")
    return "".join(out)


def _leg_mass(key: str) -> float:
    return sum(b.mass_kg for b in _leg_bodies(key))


def meta() -> dict:
    """What the worlds and the gaits read (the same keys as robots/sparc_<host>/*.json)."""
    q_eq = [float(v) for v in P.Q_EQUILIBRIUM]
    x, _, _ = dog_spine_x(*q_eq[1:])
    legs = {}
    for key in LEG_KEYS:
        prefix, parent, hip, *_ = _LEGS[key]
        legs[key] = {
            "body": parent, "haa": None, "hfe": f"joint_{prefix}_leg_upper",
            "kfe": f"joint_{prefix}_leg_lower",
            "foot_link": f"{prefix}_foot", "hip_x_m": hip[0], "hip_z_m": hip[2], "thigh_m": THIGH_M,
            "shank_m": SHANK_M, "knee_sign": KNEE_SIGN[key], "mass_kg": round(_leg_mass(key), 9),
        }
    hind_group = BODY_KG + _leg_mass("HL") + _leg_mass("HR")
    front_group = BODY_KG + _leg_mass("FL") + _leg_mass("FR")
    middle = BY_NAME["hind_spine"].mass_kg + BY_NAME["front_spine"].mass_kg
    return {
        "name": NAME,
        "host": HOST,
        "source": f"{SOURCE_URL} @ {SOURCE_COMMIT[:7]}",
        "base_link": "hind_body",
        "spine_joints": list(SPINE_JOINTS),
        "q_equilibrium": [round(v, 9) for v in q_eq],
        "x_equilibrium": [round(float(v), 9) for v in P.X_EQUILIBRIUM],
        "front_body_length_m": 0.0,  # the front body frame is at the last spine joint
        "front_hip_x_in_hind_m": round(x + legs["FL"]["hip_x_m"], 9),  # spine at q_equilibrium
        "spine_x_offset_m": round(SPINE_X_OFFSET_M, 9),
        "foot_radius_m": FOOT_RADIUS_M,
        "leg_torque_limit_nm": MOTOR_LIMIT_NM,
        "spine_torque_limit_nm": MOTOR_LIMIT_NM,
        "base_height_m": BASE_HEIGHT_M,
        "mass_kg": {"hind_group": round(hind_group, 6), "spine_middle": round(middle, 6),
                    "front_group": round(front_group, 6), "total": round(TOTAL_MASS_KG, 6)},
        "legs": legs,
    }


def readme(licence_text: str) -> str:
    m = meta()
    rows = [f"| {k} | {_f(v)} |" for k, v in sorted(m["mass_kg"].items())]
    rows += [f"| {b.name} | {_f(b.mass_kg)} |" for b in BODIES if not b.name.endswith(("_upper", "_lower",
                                                                                           "_foot"))]
    rows += [f"| leg_{k} | {_f(v['mass_kg'])} |" for k, v in m["legs"].items()]
    src = "\n".join(f"- `{path}`: sha256 `{digest}`" for path, digest in SOURCES.items())
    return (
        "# spined_dog\n\n"
        "The SPARC authors' own quadruped: two 2.044 kg bodies joined by their three-joint spine "
        "(`joint_hind_spine` -> `joint_front_spine` -> `joint_front_body`, all about y), four 2-DoF legs "
        "(hip and knee about y, no abduction), eleven torque motors clamped at +-12 N·m. Floating base "
        "`hind_body`. Only the four r = 0.03 m foot spheres collide (in MuJoCo and in pybullet).\n\n"
        f"**Provenance.** The numbers (masses, centres of mass, inertias, joint positions and axes, ranges, "
        f"motor clamps, foot radius, MuJoCo options: dt 1 ms, CG solver, 1000 iterations, tolerance 1e-8, "
        f"elliptic cones, noslip 2, floor friction 1 / 0.005 / 0.0001) are read from {SOURCE_URL}, commit "
        f"`{SOURCE_COMMIT}`:\n\n{src}\n\n"
        "Their files are not copied here: `spined_dog.xml` (MJCF), `spined_dog.urdf` and `spined_dog.json` "
        "are written by `sparc_quad/sim/spined_dog.py` from its parameter table (`sparc-quad robots "
        "generate`; a test fails when they drift, another compares them with the authors' MJCF when the "
        "snapshot is present). Differences from theirs: primitive visual shapes instead of their meshes "
        "(visual only there), the MJCF's 0.01 kg foot bodies also in the URDF, no sensors.\n\n"
        "**Masses** (kg):\n\n| part | mass_kg |\n|---|---|\n" + "\n".join(rows) + "\n\n"
        "**Licence** of the numbers (the authors' MIT licence):\n\n```\nMIT License\n\n"
        f"{COPYRIGHT}\n\n{licence_text.strip()}\n```\n"
    )


def _licence_body(root: Path) -> str:
    """The MIT licence's text after its title and copyright line (the project's LICENSE is the same MIT
    text, sha256 of theirs in SOURCES)."""
    lines = (root / "LICENSE").read_text().splitlines()
    return "\n".join(lines[3:]) + "\n"


def folder(robots_dir: Path) -> Path:
    return robots_dir / NAME


def generate(robots_dir: Path) -> dict[Path, str]:
    d = folder(robots_dir)
    return {
        d / f"{NAME}.xml": mjcf(),
        d / f"{NAME}.urdf": urdf(),
        d / f"{NAME}.json": json.dumps(meta(), indent=2, sort_keys=True) + "\n",
        d / "README.md": readme(_licence_body(Path(__file__).resolve().parents[2])),
    }
