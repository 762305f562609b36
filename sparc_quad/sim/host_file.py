"""A host quadruped as data: `host.toml`, what the spine splice and the gaits need to know of a robot.

One file per host, in the host's folder under robots/ (or anywhere, for `bound --host-file`):

    name = "go1"                                 # the host's name (letters, digits, - and _)
    description = "Unitree Go1"
    [model]
    example_robot_data = "robots/go1_description/urdf/go1.urdf"   # below example-robot-data's share folder
    # urdf = "go1.urdf"                          # or a URDF path, relative to this file
    # trunk = "base"                             # the trunk link (default: the link that carries 4 legs)
    [legs]
    knee_sign_front = -1                         # sign of the knee angle in the standing pose
    knee_sign_hind = -1
    foot_radius_m = 0.02
    torque_limit_nm = 23.7                       # every leg joint's effort limit
    velocity_limit_rad_s = 30.1
    [defaults.raibert]                           # scenario keys `bound --host go1` starts from, per gait
    frequency = 3.0

The legs are found in the URDF (four subtrees of the trunk, each one roll and two pitch joints about +y,
one foot link), so no joint names are listed; `sparc-quad robots check host.toml` says what does not fit.
The spined dog (`generator = "spined-dog"`) is the authors' own robot, built by `sim.spined_dog`.
"""

from __future__ import annotations

import importlib.metadata
import math
import re
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

HOST_FILE = "host.toml"
GENERATORS = ("splice", "spined-dog")
NAME = re.compile(r"^[a-z0-9][a-z0-9_-]{0,39}$")
_TABLES = {"name", "description", "generator", "model", "legs", "defaults"}
_MODEL = {"example_robot_data", "urdf", "trunk"}
_LEGS = {"knee_sign_front", "knee_sign_hind", "foot_radius_m", "torque_limit_nm", "velocity_limit_rad_s"}
_LIMITS = {"foot_radius_m": (1e-3, 0.2), "torque_limit_nm": (0.1, 1000.0),
           "velocity_limit_rad_s": (0.1, 500.0)}


class HostFileError(ValueError):
    """A host file that cannot be used; `problems` lists each one (a line each)."""

    def __init__(self, path: Path, problems: list[str]):
        super().__init__(f"{path}: " + "; ".join(problems))
        self.path = path
        self.problems = problems


@dataclass(frozen=True)
class HostFile:
    name: str
    path: Path  # the host.toml
    description: str = ""
    generator: str = "splice"
    erd_subpath: str | None = None  # below share/example-robot-data/
    urdf: Path | None = None  # a URDF of the user's (absolute)
    trunk: str | None = None
    knee_sign_front: int = -1
    knee_sign_hind: int = 1
    foot_radius_m: float = 0.02
    leg_torque_limit_nm: float = 10.0
    leg_velocity_limit_rad_s: float = 30.0
    defaults: dict[str, dict[str, Any]] = field(default_factory=dict)  # gait -> scenario keys

    @property
    def folder(self) -> Path:
        return self.path.parent

    @property
    def source(self) -> str:
        """Where the host's description comes from, as the generated files' headers name it."""
        return self.erd_subpath if self.erd_subpath is not None else str(self.urdf)

    def urdf_path(self) -> Path:
        """The host's own URDF on this machine."""
        if self.urdf is not None:
            return self.urdf
        return erd_urdf_path(self.erd_subpath)


ERD_DISTRIBUTION = "example-robot-data"


def erd_urdf_path(subpath: str) -> Path:
    """Locate a URDF inside the installed example-robot-data (cmeel prefix), no fixed path."""
    suffix = "share/example-robot-data/" + subpath
    try:
        dist = importlib.metadata.distribution(ERD_DISTRIBUTION)
        for f in dist.files or ():
            if str(f).replace("\\", "/").endswith(suffix):
                path = Path(dist.locate_file(f))
                if path.exists():
                    return path
    except importlib.metadata.PackageNotFoundError:
        pass
    import example_robot_data  # fallback: the package's own lookup

    return Path(example_robot_data.getModelPath(subpath)) / subpath


def _read(path: Path) -> dict:
    try:
        text = Path(path).read_text(encoding="utf-8")
    except IsADirectoryError:
        raise HostFileError(path, ["is a folder; name its host.toml"]) from None
    except OSError as exc:
        raise HostFileError(path, [f"cannot read ({exc.strerror or exc})"]) from None
    except UnicodeDecodeError:
        raise HostFileError(path, ["not UTF-8 text"]) from None
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise HostFileError(path, [f"not valid TOML ({exc})"]) from None


def _number(problems: list[str], where: str, value, lo: float, hi: float) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value) \
            or not lo <= value <= hi:
        problems.append(f"{where}: expected a number in [{lo:g}, {hi:g}], got {value!r}")
        return lo
    return float(value)


def load_host_file(path: Path) -> HostFile:
    """The host file at `path`, its keys checked (types, ranges, one source); HostFileError lists every
    problem. The URDF itself is checked by `check_host`."""
    path = Path(path).absolute()
    data = _read(path)
    problems: list[str] = []
    for key in sorted(set(data) - _TABLES):
        problems.append(f"{key}: unknown key; a host file has {', '.join(sorted(_TABLES))}")
    name = data.get("name")
    if not isinstance(name, str) or not NAME.match(name):
        problems.append(f"name: expected a lower-case name (letters, digits, - and _), got {name!r}")
        name = "?"
    generator = data.get("generator", "splice")
    if generator not in GENERATORS:
        problems.append(f"generator: one of {', '.join(GENERATORS)}, got {generator!r}")
    model, legs = data.get("model", {}), data.get("legs", {})
    defaults = data.get("defaults", {})
    for table, value in (("model", model), ("legs", legs), ("defaults", defaults)):
        if not isinstance(value, dict):
            problems.append(f"[{table}]: expected a table")
    if problems:
        raise HostFileError(path, problems)
    for key in sorted(set(model) - _MODEL):
        problems.append(f"model.{key}: unknown key; one of {', '.join(sorted(_MODEL))}")
    for key in sorted(set(legs) - _LEGS):
        problems.append(f"legs.{key}: unknown key; one of {', '.join(sorted(_LEGS))}")
    erd, urdf = model.get("example_robot_data"), model.get("urdf")
    if generator == "splice":
        if (erd is None) == (urdf is None):
            problems.append("model: give exactly one of example_robot_data (a path below its share folder) "
                            "or urdf (a path relative to this file)")
        for key in sorted(_LEGS - set(legs)):
            problems.append(f"legs.{key}: missing")
    urdf_path = None
    if urdf is not None:
        if not isinstance(urdf, str):
            problems.append(f"model.urdf: expected a path, got {urdf!r}")
        else:
            urdf_path = (path.parent / urdf).resolve()
            if not urdf_path.is_file():
                problems.append(f"model.urdf: no such file {urdf_path}")
    if erd is not None and not isinstance(erd, str):
        problems.append(f"model.example_robot_data: expected a path, got {erd!r}")
    trunk = model.get("trunk")
    if trunk is not None and not isinstance(trunk, str):
        problems.append(f"model.trunk: expected a link name, got {trunk!r}")
    signs = {}
    for key in ("knee_sign_front", "knee_sign_hind"):
        v = legs.get(key, -1)
        if v not in (-1, 1) or isinstance(v, bool):
            problems.append(f"legs.{key}: expected -1 or +1, got {v!r}")
        signs[key] = int(v) if v in (-1, 1) else -1
    nums = {key: _number(problems, f"legs.{key}", legs.get(key, lo), lo, hi)
            for key, (lo, hi) in _LIMITS.items()}
    for gait, keys in defaults.items():
        if not isinstance(keys, dict):
            problems.append(f"defaults.{gait}: expected a table of scenario keys")
    if problems:
        raise HostFileError(path, problems)
    return HostFile(name=name, path=path, description=str(data.get("description", "")), generator=generator,
                    erd_subpath=erd, urdf=urdf_path, trunk=trunk, knee_sign_front=signs["knee_sign_front"],
                    knee_sign_hind=signs["knee_sign_hind"], foot_radius_m=nums["foot_radius_m"],
                    leg_torque_limit_nm=nums["torque_limit_nm"],
                    leg_velocity_limit_rad_s=nums["velocity_limit_rad_s"],
                    defaults={g: dict(k) for g, k in defaults.items()})
