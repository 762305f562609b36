"""Where the generated URDFs live, and the one function that writes them all."""

from __future__ import annotations

from pathlib import Path

from sparc_quad.sim import quadruped_urdf
from spine_module.urdf import spine_urdf

ROBOTS_DIR = Path(__file__).resolve().parent.parent / "robots"


def spine_urdf_path(robots_dir: Path = ROBOTS_DIR) -> Path:
    return robots_dir / "sparc_spine" / "sparc_spine.urdf"


def generate_all(robots_dir: Path = ROBOTS_DIR) -> dict[Path, str]:
    """Every generated robot file: path -> text. Each robot generator adds its files here."""
    files = {spine_urdf_path(robots_dir): spine_urdf()}
    files.update(quadruped_urdf.generate(robots_dir))
    return files
