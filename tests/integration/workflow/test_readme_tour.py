"""The README's quick tour, run exactly as written (from a scratch folder that stands in for the repository
root: `studies/` is linked in, `out/` is written there). A row that does not work as written fails here."""

from __future__ import annotations

import os
import re
import shlex
import subprocess
import sys

import pytest

from tests.paths import ROOT


def tour_commands() -> list[str]:
    text = (ROOT / "README.md").read_text()
    section = text.split("## Quick tour", 1)[1].split("\n## ", 1)[0]
    rows = [line for line in section.splitlines() if line.startswith("| ") and "`sparc-quad " in line]
    return [re.findall(r"`(sparc-quad [^`]+)`", row)[-1] for row in rows]


def test_tour_has_rows():
    cmds = tour_commands()
    assert len(cmds) >= 6, cmds
    assert all(c.startswith("sparc-quad ") for c in cmds)


@pytest.mark.timeout(900)
def test_tour_runs_as_written(tmp_path):
    (tmp_path / "studies").symlink_to(ROOT / "studies")
    env = dict(os.environ, PYTHONPATH=str(ROOT), MPLBACKEND="Agg")
    for cmd in tour_commands():
        argv = [sys.executable, "-m", "sparc_quad", *shlex.split(cmd)[1:]]
        r = subprocess.run(argv, cwd=tmp_path, env=env, capture_output=True, text=True, timeout=600,
                           stdin=subprocess.DEVNULL)
        assert r.returncode == 0, f"{cmd}\nexit {r.returncode}\n{r.stderr[-3000:]}"
        assert "Traceback" not in r.stderr, f"{cmd}\n{r.stderr[-3000:]}"
    out = tmp_path / "out" / "tour"
    for path in ("b800/metrics.json", "rigid/metrics.json", "gap/report.json", "synth/trial_00.csv"):
        assert (out / path).is_file(), path
