"""Outputs written whole or not at all, so an interrupt (Ctrl-C) or a failure never leaves a partial result
beside (or over) the previous one.

A command writes into a temporary sibling of its `--out` folder (same parent, so relative paths written
inside stay valid and every rename stays on one file system). When the command completes, each file it
wrote is renamed into `--out` (os.replace: a reader sees the old file or the new one, never half of one)
with SIGINT and SIGTERM held back, so an interrupt cannot split the set. On any exception,
KeyboardInterrupt included, the sibling is removed and `--out` is left as it was. Files in `--out` that the
command does not write (another program's logs, another experiment's results) are left alone: `--out` is
not swapped as a whole, so a process still writing into it loses nothing.
"""

from __future__ import annotations

import contextlib
import os
import shutil
import signal
import tempfile
from collections.abc import Iterator
from pathlib import Path

_HELD = {signal.SIGINT, signal.SIGTERM}


def _commit(tmp: Path, out: Path) -> None:
    old_mask = signal.pthread_sigmask(signal.SIG_BLOCK, _HELD)
    try:
        out.mkdir(parents=True, exist_ok=True)
        for src in sorted(tmp.rglob("*")):  # parents sort before their contents
            dst = out / src.relative_to(tmp)
            if src.is_dir():
                dst.mkdir(exist_ok=True)
            else:
                os.replace(src, dst)
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, old_mask)


@contextlib.contextmanager
def atomic_dir(out: Path) -> Iterator[Path]:
    """A temporary folder beside `out` to write the whole result into; its files move into `out` on
    success, and it is removed either way."""
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise NotADirectoryError(f"--out {out} exists and is not a folder")
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{out.name}.tmp-", dir=out.parent))
    try:
        yield tmp
        _commit(tmp, out)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def moved(paths: list[Path], tmp: Path, out: Path) -> list[Path]:
    """Paths written under `tmp`, as they are named after the move into `out`."""
    return [out / Path(p).relative_to(tmp) for p in paths]
