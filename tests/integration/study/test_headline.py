"""The committed headline regenerates from its committed per-trial records (gzip JSON): the report's claims
and cells byte for byte, so every figure quoted from docs/study/headline/ can be re-derived:

- `sparc-quad study report docs/study/headline/parts/*/ --out docs/study/headline` (every part, the claims
  per robot, engine, gait and spine);
- the gait C part at the same command alone (docs/study/headline/gait_c/);
- the frequency window (docs/study/headline/frequency_window/), robustness beside the cost."""

from __future__ import annotations

import warnings

import pytest

from sparc_quad.study.report import write_report
from tests.paths import ROOT

HEADLINE = ROOT / "docs" / "study" / "headline"
REPORTS = {
    "headline": (sorted(p for p in (HEADLINE / "parts").iterdir() if p.is_dir()), HEADLINE,
                 ("claims.md", "cells.csv")),
    "gait_c": ([HEADLINE / "parts" / "dog_gait_c"], HEADLINE / "gait_c", ("claims.md", "cells.csv")),
    "frequency_window": ([HEADLINE / "frequency_window"], HEADLINE / "frequency_window" / "report",
                         ("frequency_window.md", "cells.csv")),
}


@pytest.mark.parametrize("name", sorted(REPORTS))
def test_committed_report_regenerates_byte_for_byte(name, tmp_path):
    folders, committed, files = REPORTS[name]
    if not all((f / "summary.json").is_file() for f in folders):
        pytest.fail(f"{name}: a study folder lacks its summary.json: {folders}")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        write_report(folders, out=tmp_path)
    for file in files:
        assert (tmp_path / file).read_bytes() == (committed / file).read_bytes(), f"{name}: {file}"
