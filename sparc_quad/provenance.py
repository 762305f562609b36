"""Which code produced a result: the package version, a hash of the sources a bound's result depends on,
and the checkout's `git describe`. Study records and every `scenario.json` carry them."""

from __future__ import annotations

import functools
import hashlib
import subprocess
from importlib import metadata
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
# package folders whose sources a trial result depends on, and the ones under them that it does not
CODE_DIRS = ("sparc_quad", "spine_module", "robots")
CODE_SUFFIXES = (".py", ".urdf", ".toml", ".json", ".yaml", ".srdf", ".stl", ".obj")
NOT_TRIAL_CODE = (
    "sparc_quad/cli/",
    "sparc_quad/gap/",
    "sparc_quad/experiments/",
    "sparc_quad/study/spec.py",
    "sparc_quad/study/records.py",
    "sparc_quad/study/executors.py",
    "sparc_quad/study/stats.py",
    "sparc_quad/study/report.py",
    "sparc_quad/study/claims.py",
    "sparc_quad/study/runner.py",
    "sparc_quad/provenance.py",
    "sparc_quad/scenario/files.py",
)


def package_version() -> str:
    try:
        return metadata.version("sparc-quad")
    except metadata.PackageNotFoundError:
        return "0+unknown"


def git_describe(root: Path = ROOT) -> str | None:
    """`git describe --always --dirty` of the checkout, for the record (not part of the hash)."""
    try:
        r = subprocess.run(
            ["git", "describe", "--always", "--dirty"],
            cwd=root,
            capture_output=True,
            text=True,
            timeout=10,
            check=False,
        )
    except (OSError, subprocess.SubprocessError):
        return None
    return r.stdout.strip() or None


def trial_source_files(root: Path = ROOT) -> list[Path]:
    files = []
    for d in CODE_DIRS:
        base = root / d
        if not base.is_dir():
            continue
        for p in base.rglob("*"):
            rel = p.relative_to(root).as_posix()
            if (
                p.is_file()
                and p.suffix in CODE_SUFFIXES
                and "__pycache__" not in rel
                and not rel.startswith(NOT_TRIAL_CODE)
                and ".egg-info" not in rel
            ):
                files.append(p)
    return sorted(files)


@functools.cache
def code_version(root: Path = ROOT) -> str:
    """package version + a hash of the trial's source files (content and path)."""
    h = hashlib.sha256()
    for p in trial_source_files(root):
        h.update(p.relative_to(root).as_posix().encode())
        h.update(b"\0")
        h.update(p.read_bytes())
        h.update(b"\0")
    return f"{package_version()}+src.{h.hexdigest()[:12]}"
