"""Every relative link in README.md, CHANGELOG.md and docs/**/*.md points at a file that exists, and a
#fragment at a heading of that file (GitHub's anchor rule), so moving a document or renaming a heading
cannot leave a dead link behind; every repository file named in backticks (`tests/...py`, `bench/...py`)
exists, so moving a test or a script cannot leave a stale path behind."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = sorted([ROOT / "README.md", ROOT / "CHANGELOG.md", *(ROOT / "docs").rglob("*.md"),
               *(ROOT / "notebook").rglob("*.md")])
FENCE = re.compile(r"^(```|~~~).*?^\1", re.M | re.S)
INLINE_CODE = re.compile(r"`[^`\n]*`")
LINK = re.compile(r"!?\[[^\]]*\]\(\s*<?([^)\s>]+)>?(?:\s+\"[^\"]*\")?\s*\)")
HEADING = re.compile(r"^#{1,6}\s+(.*?)\s*#*\s*$", re.M)
EXTERNAL = re.compile(r"^[a-z][a-z0-9+.-]*:", re.I)  # http:, https:, mailto:, ...
REPO_PATH = re.compile(r"`((?:tests|sparc_quad|spine_module|bench|robots|studies|lcm_types|docs)/[\w./-]+"
                       r"\.(?:py|toml|md|json|urdf|xml|lcm))(?:::\w+)?`")


def prose(text: str) -> str:
    """The text without fenced code blocks and inline code, where brackets are not links."""
    return INLINE_CODE.sub("", FENCE.sub("", text))


def anchor(heading: str) -> str:
    """GitHub's heading id: markup and punctuation dropped, lower case, spaces to hyphens."""
    text = re.sub(r"\[([^\]]*)\]\([^)]*\)", r"\1", heading)  # a link in a heading keeps its text
    text = text.replace("`", "").lower()
    return re.sub(r"[^\w\- ]", "", text).replace(" ", "-")


def anchors(path: Path) -> set[str]:
    seen: dict[str, int] = {}
    out = set()
    for heading in HEADING.findall(FENCE.sub("", path.read_text(encoding="utf-8"))):
        base = anchor(heading)
        n = seen.get(base, 0)
        seen[base] = n + 1
        out.add(base if n == 0 else f"{base}-{n}")
    return out


def links(path: Path) -> list[str]:
    return [t for t in LINK.findall(prose(path.read_text(encoding="utf-8"))) if not EXTERNAL.match(t)]


def shown(path: Path) -> str:
    return str(path.relative_to(ROOT)) if path.is_relative_to(ROOT) else path.name


def broken(path: Path) -> list[str]:
    bad = []
    for target in links(path):
        file_part, _, fragment = target.partition("#")
        dest = (path.parent / file_part).resolve() if file_part else path
        if not dest.exists():
            bad.append(f"{target}: no such file")
        elif fragment and dest.suffix == ".md" and fragment.lower() not in anchors(dest):
            bad.append(f"{target}: no heading #{fragment} in {shown(dest)}")
    return bad


def stale_paths(path: Path, root: Path = ROOT) -> list[str]:
    text = FENCE.sub("", path.read_text(encoding="utf-8"))
    return [p for p in REPO_PATH.findall(text) if not (root / p).exists()]


@pytest.mark.parametrize("doc", DOCS, ids=lambda p: str(p.relative_to(ROOT)))
def test_relative_links_resolve(doc):
    assert broken(doc) == []


@pytest.mark.parametrize("doc", DOCS, ids=lambda p: str(p.relative_to(ROOT)))
def test_named_repository_files_exist(doc):
    assert stale_paths(doc) == []


def test_the_checker_catches_a_dead_file_and_a_dead_anchor(tmp_path):
    (tmp_path / "b.md").write_text("# Real heading, with `code`\n\n## Real heading, with code\n")
    doc = tmp_path / "a.md"
    doc.write_text("[ok](b.md#real-heading-with-code) [ok2](b.md#real-heading-with-code-1) [web](https://x.y)\n"
                   "`[not a link](nowhere.md)`\n```\n[nor this](nowhere.md)\n```\n"
                   "[gone](missing.md) [bad anchor](b.md#nope) [self](#nope)\n")
    assert broken(doc) == ["missing.md: no such file", "b.md#nope: no heading #nope in b.md",
                           "#nope: no heading #nope in a.md"]


def test_the_checker_catches_a_moved_file(tmp_path):
    (tmp_path / "tests").mkdir()
    (tmp_path / "tests" / "test_here.py").write_text("")
    doc = tmp_path / "a.md"
    doc.write_text("`tests/test_here.py::test_x` and `tests/test_gone.py`; out/bench/x.json is not a path\n")
    assert stale_paths(doc, tmp_path) == ["tests/test_gone.py"]


def test_the_notebook_index_lists_every_measurement():
    import importlib.util

    spec = importlib.util.spec_from_file_location("notebook_index", ROOT / "notebook" / "index.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    assert (ROOT / "notebook" / "README.md").read_text() == module.index_text(), \
        "notebook/README.md is stale: run python notebook/index.py"
