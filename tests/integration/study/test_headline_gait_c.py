"""The committed gait C headline regenerates from its committed per-trial records (gzip JSON): the report's
claims and cells byte for byte, so every figure quoted from docs/study/headline/gait_c/ can be re-derived."""

from __future__ import annotations

import warnings

from sparc_quad.study.report import write_report
from tests.paths import ROOT

HEADLINE = ROOT / "docs" / "study" / "headline"


def test_gait_c_headline_regenerates_byte_for_byte(tmp_path):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        write_report([HEADLINE / "parts" / "dog_gait_c"], out=tmp_path)
    for name in ("claims.md", "cells.csv"):
        assert (tmp_path / name).read_bytes() == (HEADLINE / "gait_c" / name).read_bytes(), name
