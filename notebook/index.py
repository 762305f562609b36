"""Writes notebook/README.md: the index of the dated measurement files, from each file's date and first
heading. Run `python notebook/index.py` after adding a file; tests/test_docs_links.py fails while the
index is stale."""

from __future__ import annotations

import re
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
HEAD = """# The notebook: dated measurements

Each file here is one measurement session: the date, the commit, the machine's load, the commands and the
numbers they printed. The manual (`docs/*.md`) states the current figures, each with the command that
reproduces it, and links here for where they came from. A new measurement is a new file
(`YYYY-MM-DD-topic.md`, then `python notebook/index.py`); an old one is never edited to match newer code,
so the commands and paths in it are those of its day.

| date | measurement |
|---|---|
"""


def index_text(folder: Path = HERE) -> str:
    rows = []
    for path in sorted(folder.glob("20??-??-??-*.md")):
        first = path.read_text(encoding="utf-8").splitlines()[0].lstrip("# ").strip()
        title = re.sub(r"^\d{4}-\d{2}-\d{2}( \([^)]*\))?:\s*", "", first).replace("|", "\\|")
        rows.append(f"| {path.name[:10]} | [{title}]({path.name}) |")
    return HEAD + "\n".join(rows) + "\n"


if __name__ == "__main__":
    (HERE / "README.md").write_text(index_text())
    sys.exit(0)
