"""Host robots: the listed ones (a `host.toml` in each folder under robots/) and any host file a run names.

A listed host is known by its name (`--host go1`); a host file elsewhere (`--host-file PATH`) is spliced
on first use into a cache folder keyed by the file's and its URDF's content, and known by its path. The
spined dog is the SPARC authors' own robot, built by `sim.spined_dog` (its own generator and MJCF).
"""

from __future__ import annotations

import functools
import hashlib
import os
import tempfile
from dataclasses import dataclass
from pathlib import Path

from sparc_quad.robots import ROBOTS_DIR
from sparc_quad.sim import spined_dog
from sparc_quad.sim.host_file import HOST_FILE, HostFile, load_host_file
from sparc_quad.sim.quadruped_urdf import DEFAULT_HOST, files_of, robot_paths

__all__ = ["DEFAULT_HOST", "HOSTS", "HostFiles", "host_files", "host_of", "leg_torque_limit_nm",
           "leg_winding", "listed_hosts"]
FIRST = ("solo12", "a1", spined_dog.HOST)  # listed first, in this order; the others by name


@functools.cache
def listed_hosts(robots_dir: Path = ROBOTS_DIR) -> dict[str, HostFile]:
    """Every host with a host.toml in a folder of `robots_dir`, by name."""
    found = {}
    for path in sorted(Path(robots_dir).glob(f"*/{HOST_FILE}")):
        host = load_host_file(path)
        if host.name in found:
            raise ValueError(f"{path}: host {host.name!r} is also {found[host.name].path}")
        found[host.name] = host
    return dict(sorted(found.items(), key=lambda kv: (kv[0] not in FIRST, FIRST.index(kv[0])
                                                      if kv[0] in FIRST else 0, kv[0])))


HOSTS: tuple[str, ...] = tuple(listed_hosts())


@dataclass(frozen=True)
class HostFiles:
    urdf: Path
    meta: Path
    mjcf: Path | None  # a native MuJoCo model; None: MuJoCo loads the URDF


def host_of(host: str, robots_dir: Path = ROBOTS_DIR) -> HostFile:
    """The host file of `host`: a listed name, or the path of a host.toml."""
    listed = listed_hosts(robots_dir)
    if host in listed:
        return listed[host]
    if host.endswith(".toml"):
        return load_host_file(Path(host))
    raise ValueError(f"host must be one of {', '.join(listed)} or a host.toml path, got {host!r}")


def _cache_root() -> Path:
    base = os.environ.get("XDG_CACHE_HOME") or (Path.home() / ".cache" if Path.home().is_dir() else None)
    return Path(base or tempfile.gettempdir()) / "sparc-quad" / "hosts"


@functools.cache
def _spliced(path: str) -> Path:
    """The folder holding the spliced robot of the host file at `path` (generated once per content)."""
    host = load_host_file(Path(path))
    digest = hashlib.sha256(host.path.read_bytes() + host.urdf_path().read_bytes()).hexdigest()[:16]
    folder = _cache_root() / f"{host.name}-{digest}"
    if not robot_paths(folder, host.name)[1].is_file():
        files = files_of(host, folder)
        folder.mkdir(parents=True, exist_ok=True)
        for target, text in files.items():  # whole files or none: a racing process writes the same bytes
            tmp = target.with_suffix(target.suffix + f".{os.getpid()}.tmp")
            tmp.write_text(text)
            os.replace(tmp, target)
    return folder


def host_files(host: str, robots_dir: Path = ROBOTS_DIR) -> HostFiles:
    """The robot files a world loads for `host` (a listed name or a host.toml path)."""
    spec = host_of(host, robots_dir)
    if spec.generator == "spined-dog":
        d = spec.folder
        return HostFiles(d / f"{spined_dog.NAME}.urdf", d / f"{spined_dog.NAME}.json",
                         d / f"{spined_dog.NAME}.xml")
    folder = spec.folder if host in listed_hosts(robots_dir) else _spliced(str(spec.path))
    urdf, meta = robot_paths(folder, spec.name)
    return HostFiles(urdf, meta, None)


def leg_winding(host: str):
    """The leg actuators' winding loss (`spine_module.params.WindingLoss`) of `host`, or None where it is
    not known: only Solo12's actuator is documented here, so CoT_elec is not defined on the other hosts (it
    was computed with Solo12's constants on every host)."""
    from spine_module import params as P

    return P.SOLO12_WINDING if host == "solo12" else None


def leg_torque_limit_nm(host: str) -> float:
    """The leg motors' torque limit of `host`, N*m."""
    spec = host_of(host)
    return spined_dog.MOTOR_LIMIT_NM if spec.generator == "spined-dog" else spec.leg_torque_limit_nm


def generate(robots_dir: Path) -> dict[Path, str]:
    """Files for every spliced host listed under `robots_dir` (a `host.toml` per folder): path -> text (see
    `sparc_quad.sim.robot_files.generate_all`)."""
    files: dict[Path, str] = {}
    for host in listed_hosts.__wrapped__(robots_dir).values():
        if host.generator == "splice":
            files.update(files_of(host))
    return files
