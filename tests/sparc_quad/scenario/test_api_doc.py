"""docs/api.md's Python example runs as written (in a temporary folder)."""

from __future__ import annotations

import re

import pytest

from tests.paths import ROOT


@pytest.mark.filterwarnings("ignore:steady window")
def test_the_api_example_runs(tmp_path, monkeypatch, capsys):
    text = (ROOT / "docs" / "api.md").read_text()
    (code,) = re.findall(r"```python\n(.*?)```", text, re.S)
    monkeypatch.chdir(tmp_path)
    exec(compile(code, "docs/api.md", "exec"), {})
    out = capsys.readouterr().out
    assert "1000.0" in out and "m/s, CoT_pos" in out and "speed: acts only with gait raibert" in out
    assert (tmp_path / "out" / "api-example" / "scenario.json").is_file()
