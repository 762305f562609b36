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
