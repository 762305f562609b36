"""pybullet, imported without the build-time banner its C extension prints at import (it opened every
command's output; it goes to stderr, and stdout on some builds)."""

from __future__ import annotations

import contextlib
import os
import sys


@contextlib.contextmanager
def _silenced(stream):
    """The stream's file descriptor to /dev/null for the duration (the banner is written by C, below
    Python's sys.stdout and sys.stderr)."""
    try:
        fd = stream.fileno()
    except (AttributeError, ValueError, OSError):  # a captured or replaced stream: nothing to silence
        yield
        return
    stream.flush()
    saved = os.dup(fd)
    try:
        with open(os.devnull, "w") as null:
            os.dup2(null.fileno(), fd)
            yield
    finally:
        os.dup2(saved, fd)
        os.close(saved)


if "pybullet" not in sys.modules:
    with _silenced(sys.stdout), _silenced(sys.stderr):
        import pybullet  # noqa: F401
import pybullet as pb  # noqa: E402

__all__ = ["pb"]
