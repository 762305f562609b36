"""Where the generated URDFs live (robots/ at the repository root). Generating them is
`sparc_quad.sim.robot_files.generate_all`: this module imports nothing of the simulator, so every layer may
read the paths."""

from __future__ import annotations

from pathlib import Path

ROBOTS_DIR = Path(__file__).resolve().parent.parent / "robots"


def spine_urdf_path(robots_dir: Path = ROBOTS_DIR) -> Path:
    return robots_dir / "sparc_spine" / "sparc_spine.urdf"
