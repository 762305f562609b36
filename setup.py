"""Ships the generated robots (robots/, one folder per robot with its README, provenance and licence) inside
the wheel as `sparc_quad/_robots/`, so an installed sparc-quad simulates outside this checkout
(`sparc_quad.robots.ROBOTS_DIR` finds them there). Everything else is in pyproject.toml."""

import shutil
from pathlib import Path

from setuptools import setup
from setuptools.command.build_py import build_py

ROBOTS = Path(__file__).resolve().parent / "robots"


class BuildWithRobots(build_py):
    def run(self) -> None:
        super().run()
        if self.editable_mode:  # an editable install reads robots/ where it is
            return
        target = Path(self.build_lib) / "sparc_quad" / "_robots"
        if target.exists():
            shutil.rmtree(target)
        shutil.copytree(ROBOTS, target)


setup(cmdclass={"build_py": BuildWithRobots})
