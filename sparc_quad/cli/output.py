"""Outputs written whole or not at all, so an interrupt (Ctrl-C) or a failure never leaves a partial result
in `--out`, in place of or mixed with the previous one.

A command writes into a temporary sibling of its `--out` folder (same parent, so relative paths written
inside stay valid and every rename stays on one file system). When the command completes, each file it
wrote is renamed into `--out` (os.replace: a reader sees the old file or the new one, never half of one)
with SIGINT and SIGTERM held back, so an interrupt cannot split the set. On an interrupt, bad input
(`errors.BadInput`) or a full disk the sibling is removed and `--out` is left as it was; on any other
exception (a bug) it is kept, renamed `<out>.partial-<time>`, for diagnosis, and `--out` is still left as
it was. Files in `--out` that the command does not write (another program's logs, another experiment's
results) are left alone: `--out` is not swapped as a whole, so a process still writing into it loses nothing.
"""

from __future__ import annotations

import contextlib
import datetime
import os
import secrets
import shutil
import signal
from collections.abc import Iterator
from pathlib import Path

from sparc_quad.cli.errors import DISK_FULL as DISK_FULL_ERRNOS
from sparc_quad.cli.errors import BadInput, disk_full

_HELD = {signal.SIGINT, signal.SIGTERM}


def _current_mask() -> set[signal.Signals]:
    """This thread's signal mask, unchanged (read first, so a restore never depends on a block's result)."""
    return signal.pthread_sigmask(signal.SIG_BLOCK, ())


def _commit(tmp: Path, out: Path) -> None:
    old_mask = _current_mask()
    try:
        signal.pthread_sigmask(signal.SIG_BLOCK, _HELD)
        out.mkdir(parents=True, exist_ok=True)
        for src in sorted(tmp.rglob("*")):  # parents sort before their contents
            dst = out / src.relative_to(tmp)
            if src.is_dir():
                dst.mkdir(exist_ok=True)
            else:
                os.replace(src, dst)
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, old_mask)


def _make_tmp(path: Path) -> None:
    """Create the temporary folder (its own step, so a test can interrupt right after it)."""
    os.mkdir(path, 0o700)


@contextlib.contextmanager
def atomic_dir(out: Path) -> Iterator[Path]:
    """A temporary folder beside `out` to write the whole result into; its files move into `out` on
    success, and it is removed either way.

    SIGINT/SIGTERM are held in this thread while the folder is made and while it is removed, and the
    folder is named before it exists: an interrupt raised anywhere (also one a signal delivered to another
    thread raises here, which no mask holds back) leaves neither the folder nor a blocked mask behind."""
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise BadInput(f"--out {out} exists and is not a folder")
    old_mask = _current_mask()
    tmp: Path | None = None
    try:
        signal.pthread_sigmask(signal.SIG_BLOCK, _HELD)
        try:
            out.parent.mkdir(parents=True, exist_ok=True)
            for _ in range(100):  # named before it is made: the clean-up knows it
                tmp = out.parent / f".{out.name}.tmp-{secrets.token_hex(4)}"
                try:
                    _make_tmp(tmp)
                    break
                except FileExistsError:  # another's folder: never the clean-up's to remove
                    tmp = None
            else:
                raise OSError(f"no free temporary name beside {out}")
        except OSError as exc:
            if exc.errno in DISK_FULL_ERRNOS:  # not bad input: the same path works once there is room
                exc.left_unchanged = out  # type: ignore[attr-defined]
                raise
            raise BadInput(f"--out {out}: cannot write there ({exc.strerror or exc})") from None
        signal.pthread_sigmask(signal.SIG_SETMASK, old_mask)  # a held interrupt is raised here, inside
        yield tmp
        _commit(tmp, out)
    except Exception as exc:
        if disk_full(exc) is not None:  # half-written files on a full disk: removed below, not kept
            exc.left_unchanged = out  # type: ignore[attr-defined]
        elif tmp is not None and tmp.exists() and not isinstance(exc, BadInput):
            exc.partial_outputs = _keep(tmp, out)  # type: ignore[attr-defined]
        raise
    finally:
        try:
            signal.pthread_sigmask(signal.SIG_BLOCK, _HELD)  # a second Ctrl-C must not cut the clean-up short
        finally:
            try:
                if tmp is not None:
                    shutil.rmtree(tmp, ignore_errors=True)
            finally:
                signal.pthread_sigmask(signal.SIG_SETMASK, old_mask)


def _keep(tmp: Path, out: Path) -> Path | None:
    """The partial outputs of a failed run, renamed beside `out` (None if they could not be)."""
    stamp = datetime.datetime.now().strftime("%Y%m%dT%H%M%S")
    kept = out.parent / f"{out.name}.partial-{stamp}-{os.getpid()}"
    try:
        tmp.rename(kept)
    except OSError:
        return None
    return kept


def moved(paths: list[Path], tmp: Path, out: Path) -> list[Path]:
    """Paths written under `tmp`, as they are named after the move into `out`."""
    return [out / Path(p).relative_to(tmp) for p in paths]
