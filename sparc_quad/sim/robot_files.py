"""The one function that writes every generated robot file (spine alone, spine in each host quadruped)."""

from __future__ import annotations

from pathlib import Path

from sparc_quad.robots import ROBOTS_DIR, spine_urdf_path
from sparc_quad.sim import hosts, spined_dog
from spine_module.urdf import spine_urdf


def generate_all(robots_dir: Path = ROBOTS_DIR) -> dict[Path, str]:
    """Every generated robot file: path -> text. Each robot generator adds its files here."""
    files = {spine_urdf_path(robots_dir): spine_urdf()}
    files.update(hosts.generate(robots_dir))
    files.update(spined_dog.generate(robots_dir))
    return files
