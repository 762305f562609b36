"""Robot-side install and lazy CLI: the node's command loads nothing of simulation, plotting or statistics,
and a command whose extra is missing names it (exit 2)."""

from __future__ import annotations

import shutil
import subprocess
import sys

import numpy as np
import pytest

from spine_module.control.linalg import solve3
from tests.paths import ROOT

HEAVY = ("pybullet", "mujoco", "matplotlib", "scipy", "statsmodels", "tqdm", "example_robot_data")

LOADED_AFTER_HELP = """
import sys
from sparc_quad.cli import main
try:
    main([{args}])
except SystemExit as exc:
    assert exc.code == 0, exc.code
print("MODULES", " ".join(sorted({{m.split(".")[0] for m in sys.modules}})))
"""


@pytest.mark.parametrize("args", ["'spine-node', '--help'", "'motors', '--help'", "'spine-cmd', '--help'",
                                  "'--help'"])
def test_robot_side_help_imports_no_sim_plotting_or_statistics(args):
    out = subprocess.run([sys.executable, "-c", LOADED_AFTER_HELP.format(args=args)], cwd=ROOT,
                         capture_output=True, text=True, timeout=120, check=True).stdout
    loaded = set(out.strip().splitlines()[-1].split()[1:])  # the help text itself may name pybullet
    assert "sparc_quad" in loaded  # the probe itself ran
    assert not loaded & set(HEAVY), sorted(loaded & set(HEAVY))


def test_spine_module_node_path_imports_no_scipy_or_matplotlib():
    code = ("import sys; import spine_module.node, spine_module.control, spine_module.buses.cybergear, "
            "spine_module.buses.lcm; print(' '.join(sorted({m.split('.')[0] for m in sys.modules})))")
    loaded = set(subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True,
                                timeout=120, check=True).stdout.split())
    assert "spine_module" in loaded and not loaded & set(HEAVY), sorted(loaded & set(HEAVY))


@pytest.mark.parametrize(("command", "module", "extra"), [
    (["bound", "--duration", "0.1"], "pybullet", "sim"),
    (["bound", "--duration", "0.1", "--engine", "mujoco", "--host", "spined-dog"], "mujoco", "mujoco"),
    (["bench", "static", "--quick"], "scipy", "sim"),
    (["gap", "run", "trial.csv"], "scipy", "gap"),
])
def test_missing_extra_is_named_with_exit_2(tmp_path, command, module, extra):
    """As in a robot-side install: the module is not importable (sys.modules[name] = None blocks it)."""
    code = (f"import sys; sys.modules[{module!r}] = None\nfrom sparc_quad.cli import main\n"
            f"sys.exit(main({[*command, '--out', str(tmp_path / 'out')]!r}))")
    res = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert res.returncode == 2, res.stderr[-2000:]
    assert f"pip install 'sparc-quad[{extra}]'" in res.stderr and "Traceback" not in res.stderr
    lines = [ln for ln in res.stderr.splitlines() if not ln.startswith("pybullet build time")]
    assert len(lines) == 1, res.stderr


def test_solve3_matches_numpy():
    rng = np.random.default_rng(0)
    out = np.zeros(3)
    for _ in range(1000):
        j = rng.normal(size=(3, 3))
        a = j @ j.T + 1e-6 * np.eye(3)
        b = rng.normal(size=3)
        np.testing.assert_allclose(a @ solve3(a, b, out), b, atol=1e-9 * np.linalg.cond(a))


@pytest.mark.slow
def test_fresh_venv_robot_side_install(tmp_path):
    """`pip install .` without extras: the node runs, pybullet is absent, `bound` names its extra."""
    src = tmp_path / "src"  # a copy, so setuptools' build/ and egg-info stay out of the repository
    shutil.copytree(ROOT, src, ignore=shutil.ignore_patterns(".venv", ".git", "out", "build", "*.egg-info",
                                                            ".pytest_cache", ".ruff_cache", "__pycache__"))
    venv = tmp_path / "venv"
    subprocess.run([sys.executable, "-m", "venv", str(venv)], check=True, timeout=300)
    py = venv / "bin" / "python"
    subprocess.run([str(py), "-m", "pip", "install", "--quiet", "-c", str(ROOT / "constraints.txt"),
                    str(src)], check=True, timeout=1200, cwd=tmp_path)
    cli = str(venv / "bin" / "sparc-quad")
    assert subprocess.run([cli, "spine-node", "--help"], capture_output=True, timeout=120,
                          cwd=tmp_path).returncode == 0
    assert subprocess.run([str(py), "-c", "import pybullet"], capture_output=True, timeout=60,
                          cwd=tmp_path).returncode != 0
    for mod in ("scipy", "matplotlib", "mujoco"):
        assert subprocess.run([str(py), "-c", f"import {mod}"], capture_output=True, timeout=60,
                              cwd=tmp_path).returncode != 0, mod
    res = subprocess.run([cli, "bound", "--duration", "0.1", "--out", str(tmp_path / "b")],
                         capture_output=True, text=True, timeout=120, cwd=tmp_path)
    assert res.returncode == 2 and "pip install 'sparc-quad[sim]'" in res.stderr, res.stderr


def test_gap_synth_runs_on_the_robot_side_install(tmp_path):
    """`gap synth` needs only the robot-side install (pinocchio and numpy): with every simulator, plotting and
    statistics module blocked it still writes its trials."""
    argv = ["gap", "synth", "--trials-n", "1", "--periods", "1", "--out", str(tmp_path / "g")]
    code = (f"import sys\nfor m in {HEAVY!r}: sys.modules[m] = None\nfrom sparc_quad.cli import main\n"
            f"sys.exit(main({argv!r}))")
    res = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True, text=True,
                         timeout=300)
    assert res.returncode == 0, res.stderr[-2000:]
    assert list((tmp_path / "g").glob("*.csv"))


def test_no_third_party_banner(tmp_path):
    """pybullet's C extension prints its build time at import: a command's output starts with its own."""
    res = subprocess.run([sys.executable, "-m", "sparc_quad", "spine-node", "--motors", "inprocess",
                          "--experiment", "static", "--duration", "1"], cwd=tmp_path, capture_output=True,
                         text=True, timeout=300)
    assert res.returncode == 0, res.stderr[-2000:]
    assert "build time" not in res.stdout + res.stderr
    assert '"k_x_commanded_n_m": 500.0' in res.stdout and "N/m against the commanded 500.0 N/m" in res.stderr
