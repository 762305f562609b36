"""docs/gap.md lists every registered effect kind with its parameters and units, as the registry does."""

from __future__ import annotations

from pathlib import Path

from sparc_quad.effects import EFFECTS, markdown_table

DOC = Path(__file__).resolve().parents[3] / "docs" / "gap.md"


def test_effects_table_is_the_registry():
    text = DOC.read_text(encoding="utf-8")
    assert markdown_table() in text, "regenerate the table with sparc_quad.effects.markdown_table()"
    for name, k in EFFECTS.items():
        assert f"| `{name}` |" in text and all(f"`{p.key}` ({p.unit}" in text for p in k.PARAMS)
