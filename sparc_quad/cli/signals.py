"""SIGINT/SIGTERM as a stop request: the loops that must end cleanly (close the bus, stop the motors,
print the summary) poll an Event instead of being cut by KeyboardInterrupt wherever it lands.

SIGTERM is the normal way to stop a service (node, emulator, watchdog, echo): exit 0 after the clean stop.
Ctrl-C (SIGINT) stops it as cleanly and exits 130, as at any other moment of any command."""

from __future__ import annotations

import contextlib
import signal
import threading
from collections.abc import Iterator


class Stop(threading.Event):
    """Set by the first SIGINT or SIGTERM; `signum` says which."""

    signum: int | None = None

    def exit_code(self) -> int:
        """130 if Ctrl-C stopped the command, else 0."""
        return 130 if self.signum == signal.SIGINT else 0


@contextlib.contextmanager
def stop_on_signals() -> Iterator[Stop]:
    """A Stop event set by SIGINT/SIGTERM for the duration of the block (previous handlers restored)."""
    ev = Stop()

    def handler(signum, frame) -> None:
        if ev.signum is None:
            ev.signum = signum
        ev.set()

    old = {sig: signal.signal(sig, handler) for sig in (signal.SIGINT, signal.SIGTERM)}
    try:
        yield ev
    finally:
        for sig, handler in old.items():
            signal.signal(sig, handler)


@contextlib.contextmanager
def stop_after(stop: threading.Event, duration_s: float | None) -> Iterator[None]:
    """Set `stop` after `duration_s` of wall time (never if None) while the block runs."""
    timer = threading.Timer(duration_s, stop.set) if duration_s else None
    if timer:
        timer.start()
    try:
        yield
    finally:
        if timer:
            timer.cancel()
