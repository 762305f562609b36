"""Generate a quadruped with the SPARC spine: a host robot from example-robot-data cut in two, the SPARC
chain spliced between its hind and fore halves.

The committed `robots/sparc_<host>/sparc_<host>.urdf` (+ `.json` metadata) are this module's output; a
test fails when they drift. Run `sparc-quad robots generate` after changing a parameter.

Layout (sagittal plane, x forward, z up, all spine joints about +y):

    hind_body (root; the sim's floating base, its pitch is q1)
      |-- fixed --> hind_trunk (host trunk, hind half) -- hind legs (host's HL/HR subtrees)
      `-- q2 --> hind_spine -- q3 --> front_spine -- q4 --> front_body
                                                              `-- fixed --> front_trunk -- front legs

Choices (each one is repeated in the URDF's header comment and in docs/bounding/robots.md):
- The host's trunk is split at its middle into two halves of equal mass. Its inertia is read as that of
  a uniform box (dimensions solved from the principal moments); each half is half that box.
- Hip spacing: with the spine at its equilibrium arch (x = 0.273 m), the distance between the hind and
  front hip lines equals the host's, so the host's gait proportions carry over. The hind hips sit
  d = (host hip spacing - 0.273)/2 behind the q1 axis, the front hips d ahead of the end effector.
- The spine's links sit at the host's hip height (z = 0 of the host trunk frame).
- Simple collision (and visual) shapes: boxes for trunk halves and spine links, capsules for leg
  segments, a sphere for each foot. Host meshes are not used (they only cost speed).
- Leg inertials and joint origins are copied from the host unchanged; the leg joints' effort limit is the
  host spec's `leg_torque_limit_nm`.
"""

from __future__ import annotations

import json
import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

from sparc_quad.sim.host_file import HostFile
from spine_module import params as P

DEFAULT_HOST = "solo12"


# ---------------------------------------------------------------------------------------------------
# Host parsing
# ---------------------------------------------------------------------------------------------------
def _vec(text: str | None, n: int = 3) -> tuple[float, ...]:
    return tuple(float(v) for v in text.split()) if text else (0.0,) * n


@dataclass
class _Joint:
    name: str
    type: str
    parent: str
    child: str
    xyz: tuple[float, ...]
    rpy: tuple[float, ...]
    axis: tuple[float, ...]


@dataclass
class _Inertial:
    xyz: tuple[float, ...]
    rpy: tuple[float, ...]
    mass: float
    inertia: tuple[float, ...]  # ixx ixy ixz iyy iyz izz


def _parse(path: Path) -> tuple[dict[str, _Inertial | None], list[_Joint]]:
    root = ET.parse(path).getroot()
    links: dict[str, _Inertial | None] = {}
    for link in root.findall("link"):
        inert = link.find("inertial")
        if inert is None:
            links[link.get("name")] = None
            continue
        o = inert.find("origin")
        i = inert.find("inertia")
        links[link.get("name")] = _Inertial(
            _vec(o.get("xyz") if o is not None else None), _vec(o.get("rpy") if o is not None else None),
            float(inert.find("mass").get("value")),
            tuple(float(i.get(k, "0")) for k in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")),
        )
    joints = []
    for j in root.findall("joint"):
        o = j.find("origin")
        a = j.find("axis")
        joints.append(_Joint(
            j.get("name"), j.get("type"), j.find("parent").get("link"), j.find("child").get("link"),
            _vec(o.get("xyz") if o is not None else None), _vec(o.get("rpy") if o is not None else None),
            _vec(a.get("xyz")) if a is not None else (1.0, 0.0, 0.0),
        ))
    return links, joints


@dataclass
class _Leg:
    key: str  # FL, FR, HL, HR
    root: _Joint
    joints: list[_Joint]  # the subtree's joints, depth-first from the root
    haa: str
    hfe: str
    kfe: str
    foot_link: str
    hip_xz_host: tuple[float, float]  # HFE axis in host trunk frame (x, z)
    thigh_m: float
    shank_m: float


def _children(joints: list[_Joint], link: str) -> list[_Joint]:
    return [j for j in joints if j.parent == link]


def _subtree(joints: list[_Joint], root: _Joint) -> list[_Joint]:
    out = [root]
    for j in _children(joints, root.child):
        out.extend(_subtree(joints, j))
    return out


def _leg(joints: list[_Joint], root: _Joint) -> _Leg:
    sub = _subtree(joints, root)
    for j in sub:
        if any(abs(v) > 1e-9 for v in j.rpy):
            raise ValueError(f"leg joint {j.name} has a rotated origin; the generator assumes none")
    moving = [j for j in sub if j.type in ("revolute", "continuous")]
    pitch = [j for j in moving if abs(j.axis[1]) > 0.9]
    roll = [j for j in moving if abs(j.axis[0]) > 0.9]
    if len(pitch) != 2 or len(roll) != 1 or any(j.axis[1] < 0 for j in pitch):
        raise ValueError(f"leg at {root.name}: expected one roll joint and two +y pitch joints")
    hfe, kfe = pitch
    by_child = {j.child: j for j in sub}

    def origin_in_trunk(link: str) -> tuple[float, float, float]:
        x = y = z = 0.0
        while link in by_child:
            j = by_child[link]
            x, y, z = x + j.xyz[0], y + j.xyz[1], z + j.xyz[2]
            link = j.parent
        return x, y, z

    below_knee = _subtree(joints, kfe)
    leaves = [j.child for j in below_knee if not _children(joints, j.child)]
    if len(leaves) != 1:
        raise ValueError(f"leg at {root.name}: expected one foot link below the knee, got {leaves}")
    foot = leaves[0]
    hip = origin_in_trunk(hfe.child)
    knee = origin_in_trunk(kfe.child)
    toe = origin_in_trunk(foot)
    key = ("F" if root.xyz[0] > 0 else "H") + ("L" if root.xyz[1] > 0 else "R")
    thigh = math.hypot(knee[0] - hip[0], knee[2] - hip[2])
    shank = math.hypot(toe[0] - knee[0], toe[2] - knee[2])
    return _Leg(key, root, sub, roll[0].name, hfe.name, kfe.name, foot, (hip[0], hip[2]), thigh, shank)


def _box_from_inertia(mass: float, ixx: float, iyy: float, izz: float) -> tuple[float, float, float]:
    """Dimensions (a along x, b along y, c along z) of the uniform box with these principal moments."""
    a2 = 6.0 * (iyy + izz - ixx) / mass
    b2 = 6.0 * (ixx + izz - iyy) / mass
    c2 = 6.0 * (ixx + iyy - izz) / mass
    return tuple(math.sqrt(max(v, 1e-4)) for v in (a2, b2, c2))  # type: ignore[return-value]


# ---------------------------------------------------------------------------------------------------
# URDF text
# ---------------------------------------------------------------------------------------------------
def _f(v: float) -> str:
    s = f"{v:.9g}"
    return "0" if s in ("-0", "0") else s


def _xyz(v) -> str:
    return " ".join(_f(x) for x in v)


def _inertial_xml(xyz, mass: float, inertia) -> str:
    ixx, ixy, ixz, iyy, iyz, izz = inertia
    return (f'    <inertial>\n      <origin xyz="{_xyz(xyz)}" rpy="0 0 0"/>\n'
            f'      <mass value="{_f(mass)}"/>\n'
            f'      <inertia ixx="{_f(ixx)}" ixy="{_f(ixy)}" ixz="{_f(ixz)}" iyy="{_f(iyy)}" iyz="{_f(iyz)}"'
            f' izz="{_f(izz)}"/>\n    </inertial>\n')


def _shape_xml(geometry: str, xyz, rpy=(0.0, 0.0, 0.0), color: str = "grey") -> str:
    origin = f'<origin xyz="{_xyz(xyz)}" rpy="{_xyz(rpy)}"/>'
    return (f'    <visual>\n      {origin}\n      <geometry>{geometry}</geometry>\n'
            f'      <material name="{color}"/>\n    </visual>\n'
            f'    <collision>\n      {origin}\n      <geometry>{geometry}</geometry>\n    </collision>\n')


def _capsule_xml(vec, radius: float, color: str) -> str:
    """A capsule from the link origin along `vec` (its axis is the URDF capsule's z)."""
    length = math.sqrt(sum(c * c for c in vec))
    ux, uy, uz = (c / length for c in vec)
    rpy = (-math.asin(max(-1.0, min(1.0, uy))), math.atan2(ux, uz), 0.0)
    mid = tuple(0.5 * c for c in vec)
    return _shape_xml(f'<capsule radius="{_f(radius)}" length="{_f(length)}"/>', mid, rpy, color)


def _joint_xml(name: str, jtype: str, parent: str, child: str, xyz, axis=None, limit=None) -> str:
    s = (f'  <joint name="{name}" type="{jtype}">\n    <parent link="{parent}"/>\n'
         f'    <child link="{child}"/>\n'
         f'    <origin xyz="{_xyz(xyz)}" rpy="0 0 0"/>\n')
    if axis is not None:
        s += f'    <axis xyz="{_xyz(axis)}"/>\n'
    if limit is not None:
        lo, hi, effort, vel = limit
        s += (f'    <limit lower="{_f(lo)}" upper="{_f(hi)}" effort="{_f(effort)}" velocity="{_f(vel)}"/>\n'
              f'    <dynamics damping="0" friction="0"/>\n')
    return s + "  </joint>\n"


MIN_MASS_KG = 1e-3  # pybullet mishandles massless child links; frames get this token mass
MIN_INERTIA = (1e-7, 0.0, 0.0, 1e-7, 0.0, 1e-7)


def _spine_inertia(link: P.LinkParams) -> tuple[float, ...]:
    ixx, iyy, izz = link.inertia_kg_m2
    return (ixx, 0.0, 0.0, iyy, 0.0, izz)


@dataclass
class QuadModel:
    """The generated robot: URDF text and the metadata the sim and gait read."""

    name: str
    urdf: str
    meta: dict


def quadruped(host: HostFile, spine: P.SpineParams = P.DEFAULT_SPINE) -> QuadModel:
    """The host of `host` (a host file) with the SPARC spine spliced in; ValueError naming what in its URDF
    does not fit (trunk, legs, joints)."""
    spec = host
    src = host.urdf_path()
    try:
        links, joints = _parse(src)
    except (ET.ParseError, AttributeError, TypeError, ValueError) as exc:
        raise ValueError(f"{src}: not a URDF the splice can read ({exc})") from None
    if host.trunk is not None:
        if host.trunk not in links:
            raise ValueError(f"trunk link {host.trunk!r} is not in {src}")
        trunk = host.trunk
    else:
        trunk = next((name for name in links if
                      len([j for j in _children(joints, name) if j.type in ("revolute", "continuous")]) >= 4),
                     None)
        if trunk is None:
            raise ValueError(f"{src}: no link carries four legs (give model.trunk)")
    host = spec.name
    legs = {leg.key: leg for leg in
            (_leg(joints, j) for j in _children(joints, trunk) if j.type in ("revolute", "continuous"))}
    if sorted(legs) != ["FL", "FR", "HL", "HR"]:
        raise ValueError(f"host {host}: expected four legs, got {sorted(legs)}")

    hb, hs, fs, fb = spine.links
    x_eq = float(P.X_EQUILIBRIUM[0])
    hip_front = 0.5 * (legs["FL"].hip_xz_host[0] + legs["FR"].hip_xz_host[0])
    hip_hind = 0.5 * (legs["HL"].hip_xz_host[0] + legs["HR"].hip_xz_host[0])
    d = max(0.0, 0.5 * ((hip_front - hip_hind) - x_eq))
    hind_trunk_x = -d - hip_hind  # host trunk origin in the hind_body frame
    front_trunk_x = fb.length_m + d - hip_front  # host trunk origin in the front_body frame

    ti = links[trunk]
    a, b, c = _box_from_inertia(ti.mass, ti.inertia[0], ti.inertia[3], ti.inertia[5])
    half_m = 0.5 * ti.mass
    half_inertia = (half_m / 12 * (b * b + c * c), 0.0, 0.0, half_m / 12 * (0.25 * a * a + c * c), 0.0,
                    half_m / 12 * (0.25 * a * a + b * b))
    foot_r = spec.foot_radius_m
    cap_r = 0.5 * foot_r

    limit = _f(spec.leg_torque_limit_nm)
    limit_text = (f"Leg joint effort limit {limit} N*m (an assumption; see HOSTS in the\ngenerator).\n"
                  if spec.name in _ORIGINAL else
                  f"Leg joint effort limit {limit} N*m (from its {spec.path.name}).\n")
    header = (
        f"Generated by sparc_quad/sim/quadruped_urdf.py from spine_module/params.py and\n"
        f"{_source_text(spec)} (host '{host}'). Do not edit by hand. SI units.\n"
        f"SPARC spine spliced between the host's hind and fore halves:\n"
        f"  hind_body (root, floating base; its pitch is q1) -> q2 -> hind_spine -> q3 -> front_spine\n"
        f"  -> q4 -> front_body. Hind legs on hind_trunk (fixed to hind_body), front legs on front_trunk\n"
        f"  (fixed to front_body). Spine joints about +y; links along +x with Table III lengths;\n"
        f"  equilibrium arch q2..q4 = ({_f(P.Q_EQUILIBRIUM[1])}, {_f(P.Q_EQUILIBRIUM[2])}, "
        f"{_f(P.Q_EQUILIBRIUM[3])}) rad puts the front body's tip at x = {_f(x_eq)} m.\n"
        f"Host trunk ({_f(ti.mass)} kg) split in two equal halves, each half of the uniform box\n"
        f"({_f(a)} x {_f(b)} x {_f(c)} m) with the host trunk's principal moments.\n"
        f"Hips {_f(d)} m behind the q1 axis and {_f(d)} m ahead of the spine's end effector, so the hip\n"
        f"spacing at the equilibrium arch equals the host's ({_f(hip_front - hip_hind)} m).\n"
        f"Collision shapes: boxes, capsules (r = {_f(cap_r)} m) and foot spheres (r = {_f(foot_r)} m).\n"
        + limit_text
    )
    header = header.replace("--", "- -")  # XML comments cannot hold a double hyphen (a path may)
    out = ['<?xml version="1.0"?>\n', f"<!--\n{header}-->\n", f'<robot name="sparc_{host}">\n',
           '  <material name="grey"><color rgba="0.7 0.7 0.7 1"/></material>\n',
           '  <material name="spine"><color rgba="0.9 0.5 0.1 1"/></material>\n',
           '  <material name="leg"><color rgba="0.3 0.3 0.35 1"/></material>\n',
           '  <material name="foot"><color rgba="0.1 0.1 0.1 1"/></material>\n']

    def spine_link(link: P.LinkParams) -> str:
        box = f'<box size="{_f(link.length_m)} 0.05 0.03"/>'
        return (f'  <link name="{link.name}">\n'
                + _inertial_xml((link.com_x_m, 0, 0), link.mass_kg, _spine_inertia(link))
                + _shape_xml(box, (0.5 * link.length_m, 0, 0), color="spine") + "  </link>\n")

    def trunk_half(name: str, sign: int) -> str:
        com = (ti.xyz[0] + sign * 0.25 * a, ti.xyz[1], ti.xyz[2])
        box = f'<box size="{_f(0.5 * a)} {_f(b)} {_f(c)}"/>'
        return (f'  <link name="{name}">\n' + _inertial_xml(com, half_m, half_inertia)
                + _shape_xml(box, com) + "  </link>\n")

    def leg_xml(leg: _Leg, parent: str) -> str:
        s = []
        for j in leg.joints:
            jparent = parent if j is leg.root else j.parent
            if j.type in ("revolute", "continuous"):
                lim = (-math.pi, math.pi, spec.leg_torque_limit_nm, spec.leg_velocity_limit_rad_s)
                s.append(_joint_xml(j.name, "revolute", jparent, j.child, j.xyz, j.axis, lim))
            else:
                s.append(_joint_xml(j.name, "fixed", jparent, j.child, j.xyz))
            inert = links[j.child]
            body = ""
            if inert is not None and inert.mass >= MIN_MASS_KG:
                if any(abs(v) > 1e-9 for v in inert.rpy):
                    raise ValueError(f"link {j.child}: rotated inertial frames are not supported")
                body += _inertial_xml(inert.xyz, inert.mass, inert.inertia)
            else:
                body += _inertial_xml((0, 0, 0), MIN_MASS_KG, MIN_INERTIA)
            if j.child == leg.foot_link:
                body += _shape_xml(f'<sphere radius="{_f(foot_r)}"/>', (0, 0, 0), color="foot")
            else:
                for cj in _children(joints, j.child):
                    length = math.sqrt(sum(v * v for v in cj.xyz))
                    if length > 0.04:
                        frac = 0.7 if cj.child == leg.foot_link else 1.0  # keep the shank off the ground
                        body += _capsule_xml(tuple(frac * v for v in cj.xyz), cap_r, "leg")
            s.append(f'  <link name="{j.child}">\n{body}  </link>\n')
        return "".join(s)

    out.append(spine_link(hb))
    out.append(_joint_xml("hind_trunk_joint", "fixed", hb.name, "hind_trunk", (hind_trunk_x, 0, 0)))
    out.append(trunk_half("hind_trunk", -1))
    for key in ("HL", "HR"):
        out.append(leg_xml(legs[key], "hind_trunk"))
    chain = [(hb, hs, "q2"), (hs, fs, "q3"), (fs, fb, "q4")]
    for parent, child, jn in chain:
        out.append(_joint_xml(jn, "revolute", parent.name, child.name, (parent.length_m, 0, 0), (0, 1, 0),
                              (spine.lower_rad[jn], spine.upper_rad[jn], spine.torque_limit_nm,
                               spine.velocity_limit_rad_s)))
        out.append(spine_link(child))
    out.append(_joint_xml("front_trunk_joint", "fixed", fb.name, "front_trunk", (front_trunk_x, 0, 0)))
    out.append(trunk_half("front_trunk", +1))
    for key in ("FL", "FR"):
        out.append(leg_xml(legs[key], "front_trunk"))
    out.append("</robot>\n")

    def leg_mass(leg: _Leg) -> float:
        return sum((links[j.child].mass if links[j.child] is not None else 0.0) for j in leg.joints)

    hind_mass = hb.mass_kg + half_m + leg_mass(legs["HL"]) + leg_mass(legs["HR"])
    front_mass = fb.mass_kg + half_m + leg_mass(legs["FL"]) + leg_mass(legs["FR"])
    mid_mass = hs.mass_kg + fs.mass_kg
    leg_meta = {}
    for key, leg in sorted(legs.items()):
        trunk_x = hind_trunk_x if key[0] == "H" else front_trunk_x
        leg_meta[key] = {
            "body": hb.name if key[0] == "H" else fb.name,
            "haa": leg.haa, "hfe": leg.hfe, "kfe": leg.kfe, "foot_link": leg.foot_link,
            "hip_x_m": round(trunk_x + leg.hip_xz_host[0], 9), "hip_z_m": round(leg.hip_xz_host[1], 9),
            "thigh_m": round(leg.thigh_m, 9), "shank_m": round(leg.shank_m, 9),
            "knee_sign": spec.knee_sign_front if key[0] == "F" else spec.knee_sign_hind,
            "mass_kg": round(leg_mass(leg), 9),
        }
    meta = {
        "name": f"sparc_{host}",
        "host": host,
        "host_urdf": spec.source,
        "base_link": hb.name,
        "spine_joints": list(P.ACTUATED_JOINTS),
        "q_equilibrium": [round(float(v), 9) for v in P.Q_EQUILIBRIUM],
        "x_equilibrium": [round(float(v), 9) for v in P.X_EQUILIBRIUM],
        "front_body_length_m": fb.length_m,
        "hip_offset_m": round(d, 9),
        "hip_spacing_m": round(hip_front - hip_hind, 9),
        "foot_radius_m": foot_r,
        "leg_torque_limit_nm": spec.leg_torque_limit_nm,
        "spine_torque_limit_nm": spine.torque_limit_nm,
        "mass_kg": {
            "hind_group": round(hind_mass, 6), "spine_middle": round(mid_mass, 6),
            "front_group": round(front_mass, 6), "total": round(hind_mass + mid_mass + front_mass, 6),
            "host_trunk": ti.mass, "spine_module": round(P.MODULE_MASS_KG, 6),
        },
        "legs": leg_meta,
    }
    return QuadModel(f"sparc_{host}", "".join(out), meta)


def _source_text(spec: HostFile) -> str:
    if spec.erd_subpath is not None:
        return f"example-robot-data's {spec.erd_subpath}"
    return f"the URDF {spec.urdf.name} named by {spec.path.name}"


# the hosts whose generated files predate host files: their URDF headers keep their words (same bytes)
_ORIGINAL = ("solo12", "a1")


def robot_paths(folder: Path, host: str) -> tuple[Path, Path]:
    """The generated URDF and metadata of spliced host `host` in `folder`."""
    return folder / f"sparc_{host}.urdf", folder / f"sparc_{host}.json"


def files_of(host: HostFile, folder: Path | None = None) -> dict[Path, str]:
    """The generated files of a spliced host (path -> text), in `folder` (default: its host file's)."""
    model = quadruped(host)
    urdf_path, meta_path = robot_paths(folder or host.folder, host.name)
    return {urdf_path: model.urdf, meta_path: json.dumps(model.meta, indent=2, sort_keys=True) + "\n"}
