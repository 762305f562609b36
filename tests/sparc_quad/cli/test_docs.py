"""docs/cli.md: every example in its sh block runs as written (exit 0), and every command is in its table."""

from __future__ import annotations

import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

from sparc_quad.cli import build_parser

ROOT = Path(__file__).resolve().parents[3]
DOC = (ROOT / "docs" / "cli.md").read_text()
EXAMPLES = [line for block in re.findall(r"```sh\n(.*?)```", DOC, re.S) for line in block.splitlines()
            if line.startswith("sparc-quad ")]


@pytest.mark.integration  # one process per example, ~5-20 s each: not in the unit tier
@pytest.mark.timeout(300)
@pytest.mark.parametrize("line", EXAMPLES)
def test_example_runs_as_written(line, tmp_path):
    # `sparc-quad` is this checkout's program (a shell function, so no install is needed)
    script = (f"export PYTHONPATH={shlex.quote(str(ROOT))}\n"
              f'sparc-quad() {{ {shlex.quote(sys.executable)} -m sparc_quad "$@"; }}\n')
    for earlier in EXAMPLES[:EXAMPLES.index(line)]:  # the examples build on each other (gap synth, run)
        if " gap synth " in f" {earlier} ":
            script += earlier + " > /dev/null\n"
    res = subprocess.run(["bash", "-c", script + line], cwd=tmp_path, capture_output=True, text=True,
                         timeout=300)
    assert res.returncode == 0, res.stderr[-3000:]
    assert "Traceback" not in res.stderr


def test_every_command_is_in_the_table():
    parser = build_parser()
    sub = next(a for a in parser._actions if a.dest == "command")
    for name in sub.choices:
        assert f"| `{name}" in DOC, name
