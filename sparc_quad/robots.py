"""Where the generated robot files live: `sparc_quad/_robots/` in an installed wheel (setup.py copies
robots/ there), robots/ at the repository root in a checkout. Generating them is
`sparc_quad.sim.robot_files.generate_all`: this module imports nothing of the simulator, so every layer may
read the paths."""

from __future__ import annotations

from pathlib import Path

_PACKAGED = Path(__file__).resolve().parent / "_robots"
ROBOTS_DIR = _PACKAGED if _PACKAGED.is_dir() else Path(__file__).resolve().parent.parent / "robots"


def spine_urdf_path(robots_dir: Path = ROBOTS_DIR) -> Path:
    return robots_dir / "sparc_spine" / "sparc_spine.urdf"
