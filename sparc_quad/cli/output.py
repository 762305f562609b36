"""Output folders written whole or not at all, so an interrupt (Ctrl-C) or a failure never leaves a mix of an
old result and a partial new one.

A command writes into a temporary sibling of its `--out` folder (same parent, so relative paths written
inside stay valid and the final rename stays on one file system); when the command completes, the sibling
takes the folder's place (one atomic exchange where the kernel offers renameat2, else two renames). On any
exception, KeyboardInterrupt included, the sibling is removed and the old folder is left as it was.
"""

from __future__ import annotations

import contextlib
import ctypes
import os
import shutil
import tempfile
from collections.abc import Iterator
from pathlib import Path

_AT_FDCWD = -100
_RENAME_EXCHANGE = 2


def _exchange(a: Path, b: Path) -> bool:
    """Swap two existing paths atomically (Linux renameat2); False where that is not available."""
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        fn = libc.renameat2
    except (OSError, AttributeError):
        return False
    fn.argtypes = [ctypes.c_int, ctypes.c_char_p, ctypes.c_int, ctypes.c_char_p, ctypes.c_uint]
    return fn(_AT_FDCWD, os.fsencode(a), _AT_FDCWD, os.fsencode(b), _RENAME_EXCHANGE) == 0


def _replace_dir(new: Path, out: Path) -> None:
    if not out.exists():
        new.rename(out)
        return
    if _exchange(new, out):  # `new` now holds the old result
        shutil.rmtree(new, ignore_errors=True)
        return
    old = Path(tempfile.mkdtemp(prefix=f".{out.name}.old-", dir=out.parent))
    old.rmdir()
    out.rename(old)
    new.rename(out)
    shutil.rmtree(old, ignore_errors=True)


@contextlib.contextmanager
def atomic_dir(out: Path, *, keep_others: bool = False) -> Iterator[Path]:
    """A temporary folder beside `out` to write the whole result into; it becomes `out` on success.

    `keep_others`: files already in `out` that this run does not write are carried over (for commands that
    share a folder, as the bench experiments do); otherwise the folder holds exactly the new result.
    """
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise NotADirectoryError(f"--out {out} exists and is not a folder")
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{out.name}.tmp-", dir=out.parent))
    try:
        yield tmp
        if keep_others and out.is_dir():
            for item in out.iterdir():
                dest = tmp / item.name
                if not dest.exists() and not item.name.startswith("."):
                    (shutil.copytree if item.is_dir() else shutil.copy2)(item, dest)
        _replace_dir(tmp, out)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise


def moved(paths: list[Path], tmp: Path, out: Path) -> list[Path]:
    """Paths written under `tmp`, as they are named after the folder became `out`."""
    return [out / Path(p).relative_to(tmp) for p in paths]
