"""pybullet, imported without the build-time banner its C extension prints on stdout at import (it would
open every command's output and every JSON a command prints on stdout)."""

from __future__ import annotations

import contextlib
import os
import sys


@contextlib.contextmanager
def _stdout_silenced():
    """fd 1 to /dev/null for the duration (the banner is written by C, below sys.stdout)."""
    try:
        fd = sys.stdout.fileno()
    except (AttributeError, ValueError, OSError):  # a captured or replaced stdout: nothing to silence
        yield
        return
    sys.stdout.flush()
    saved = os.dup(fd)
    try:
        with open(os.devnull, "w") as null:
            os.dup2(null.fileno(), fd)
            yield
    finally:
        os.dup2(saved, fd)
        os.close(saved)


if "pybullet" not in sys.modules:
    with _stdout_silenced():
        import pybullet  # noqa: F401
import pybullet as pb  # noqa: E402

__all__ = ["pb"]
