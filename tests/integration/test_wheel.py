"""A wheel that simulates: built from this checkout, installed with [sim] into a fresh venv outside the
repository, it bounds for 1 s and makes synthetic gap trials (the robots ship inside it)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import venv
from pathlib import Path

import pytest

from tests.paths import ROOT


@pytest.fixture(scope="module")
def installed(tmp_path_factory) -> Path:
    """A venv outside the repository with the built wheel and its [sim] extra (versions pinned by
    constraints.txt, as `make install` pins them)."""
    base = tmp_path_factory.mktemp("wheel")
    wheels = base / "dist"
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "VIRTUAL_ENV")}
    subprocess.run([sys.executable, "-m", "pip", "wheel", "--quiet", "--no-deps", "-w", str(wheels),
                    str(ROOT)], check=True, timeout=600, env=env, cwd=base)
    (wheel,) = wheels.glob("sparc_quad-*.whl")
    target = base / "venv"
    venv.EnvBuilder(with_pip=True).create(target)
    py = target / "bin" / "python"
    subprocess.run([str(py), "-m", "pip", "install", "--quiet", "-c", str(ROOT / "constraints.txt"),
                    f"{wheel}[sim]"], check=True, timeout=900, env=env, cwd=base)
    return target


def _run(venv_dir: Path, *args: str, cwd: Path) -> subprocess.CompletedProcess:
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "VIRTUAL_ENV")}
    return subprocess.run([str(venv_dir / "bin" / "sparc-quad"), *args], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=600)


def test_the_installed_wheel_bounds_outside_the_repository(installed, tmp_path):
    r = _run(installed, "bound", "--duration", "1", "--no-plots", "--out", str(tmp_path / "b"), cwd=tmp_path)
    assert r.returncode == 0, r.stderr[-3000:]
    doc = json.loads((tmp_path / "b" / "scenario.json").read_text())
    assert doc["scenario"]["host"] == "solo12"
    loc = subprocess.run([str(installed / "bin" / "python"), "-c",
                          "import sparc_quad.robots as r; print(r.ROBOTS_DIR)"], capture_output=True,
                         text=True, cwd=tmp_path, check=True).stdout.strip()
    assert str(installed) in loc and not loc.startswith(str(ROOT))  # the wheel's robots, not the checkout's


def test_the_installed_wheel_makes_gap_trials(installed, tmp_path):
    r = _run(installed, "gap", "synth", "--trials-n", "1", "--periods", "1", "--out", str(tmp_path / "g"),
             cwd=tmp_path)
    assert r.returncode == 0, r.stderr[-3000:]
    assert list((tmp_path / "g").glob("*.csv"))
