"""The two ways a command fails: bad input (exit 2, one line naming what was wrong) and everything else.

A command raises `BadInput` for what the user can fix: a value out of range, a path it cannot write, a bus
that cannot be opened. `sparc_quad.cli.main` prints it as one line and exits 2. Any other exception is a
bug: exit 1, "internal error", the traceback in a log file (`internal_error`), never reported as bad input.
Library errors that mean bad input (a trial file that cannot be read, a spec with a bad key) are turned into
`BadInput` where the command calls the library, with `bad_input(TheirError, ...)`, and nowhere else.
"""

from __future__ import annotations

import contextlib
import datetime
import errno
import os
import sys
import tempfile
import traceback
from collections.abc import Iterator
from pathlib import Path


class BadInput(Exception):
    """Input the user can fix; the message names the option or file and what is wrong with it."""


@contextlib.contextmanager
def bad_input(*types: type[BaseException], prefix: str = "") -> Iterator[None]:
    """Re-raise the listed library errors as BadInput (their message, after `prefix`)."""
    try:
        yield
    except types as exc:
        raise BadInput(f"{prefix}{exc}") from exc


DISK_FULL = (errno.ENOSPC, errno.EDQUOT)  # the file system (or the user's quota) has no room left


def disk_full(exc: BaseException) -> OSError | None:
    """The OSError saying the disk is full behind `exc` (itself, or what it was raised from or during),
    else None. A full disk is neither bad input nor a bug: one line naming it, exit 1 (`report_disk_full`)."""
    seen: set[int] = set()
    todo: list[BaseException | None] = [exc]
    while todo:
        e = todo.pop()
        if e is None or id(e) in seen:
            continue
        seen.add(id(e))
        if isinstance(e, OSError) and e.errno in DISK_FULL:
            return e
        todo += [e.__cause__, e.__context__]
    return None


def report_disk_full(command: str, exc: BaseException, full: OSError, args: object) -> int:
    """One line: what the file system said, where (the file, else the command's --out) and what was kept;
    exit 1. `cli.output.atomic_dir` marks the exception with the folder it left as it was."""
    kept = getattr(exc, "left_unchanged", None)
    where = kept or full.filename or getattr(args, "out", None)
    who = " ".join(filter(None, ("sparc-quad", command)))
    print(f"{who}: error: {full.strerror or full}{f' writing {where}' if where else ''}"
          f"{' (left as it was: the partial outputs were removed)' if kept else ''}", file=sys.stderr)
    return 1


def log_dir(args: object) -> Path:
    """Where an internal error's traceback goes: the parent of the command's output folder (beside the
    kept partial outputs), else the system's temporary folder."""
    out = getattr(args, "out", None)
    if out:
        parent = Path(out).resolve().parent
        if parent.is_dir() and os.access(parent, os.W_OK):
            return parent
    return Path(tempfile.gettempdir())


def internal_error(command: str, exc: BaseException, args: object, verbose: bool) -> int:
    """Report a bug: one line on stderr, the traceback in a log file (or on stderr with -v); exit 1."""
    text = "".join(traceback.format_exception(exc))
    where = "traceback above"
    if verbose:
        sys.stderr.write(text)
    else:
        stamp = datetime.datetime.now().strftime("%Y%m%dT%H%M%S")
        name = command.replace(" ", "-") or "cli"
        path = log_dir(args) / f"sparc-quad-{name}-internal-error-{stamp}-{os.getpid()}.log"
        try:
            path.write_text(f"sparc-quad {command}: argv {sys.argv!r}\n{text}")
            where = f"traceback in {path}"
        except OSError:
            sys.stderr.write(text)
    partial = getattr(exc, "partial_outputs", None)
    kept = f"; partial outputs kept in {partial}" if partial else ""
    who = " ".join(filter(None, ("sparc-quad", command)))
    print(f"{who}: internal error (a bug, not bad input): {type(exc).__name__}: {exc}; {where}{kept}",
          file=sys.stderr)
    return 1
