"""In-process motor bus: the node and a simulated robot in one process, coupled by two mailboxes.

`InProcessLink` holds the mailboxes; `InProcessBus` is the node's end (a `MotorBus`), `link.robot` the
robot's end. Works single-threaded (lockstep: robot publishes, node steps, robot takes the command) and
across threads (a blocking `receive(timeout)` waits on a condition variable). Objects are passed as
copies, never shared, so neither side can mutate the other's arrays.
"""

from __future__ import annotations

import threading
import time

from spine_module.buses.base import MotorBus, MotorBusError, MotorCommand, MotorFeedback


class InProcessLink:
    def __init__(self) -> None:
        # a plain lock taken directly (`with link._lock`, a C-level context manager: the Condition's own
        # __enter__ is a Python frame per use); the condition waits and notifies on the same lock
        self._lock = threading.Lock()
        self._cv = threading.Condition(self._lock)
        self._feedback: MotorFeedback | None = None
        self._command: tuple[MotorCommand, int] | None = None
        self.dropped_feedback = 0  # feedback overwritten before the node read it
        self.dropped_commands = 0
        self.waiting = 0  # threads blocked on _cv (changed under it): a send with nobody waiting skips notify
        self.robot = RobotEnd(self)
        self.closed = False


class RobotEnd:
    """The robot's end of an in-process link."""

    def __init__(self, link: InProcessLink) -> None:
        self._link = link

    def publish_feedback(self, fb: MotorFeedback) -> None:
        link = self._link
        with link._lock:
            if link._feedback is not None:
                link.dropped_feedback += 1
            link._feedback = fb.copy()
            if link.waiting:
                link._cv.notify_all()

    def take_command(self, timeout_s: float | None = 0.0) -> tuple[MotorCommand, int] | None:
        """Newest command not yet taken and the feedback seq it answers (-1 if none), or None."""
        link = self._link
        with link._lock:
            if link._command is None and timeout_s:
                link.waiting += 1
                try:
                    link._cv.wait_for(lambda: link._command is not None, timeout_s)
                finally:
                    link.waiting -= 1
            out, link._command = link._command, None
            return out


class InProcessBus(MotorBus):
    """The node's end of an `InProcessLink`."""

    def __init__(self, link: InProcessLink | None = None) -> None:
        self.link = link if link is not None else InProcessLink()
        self._last_feedback_seq = -1

    def send(self, command: MotorCommand) -> None:
        link = self.link
        if link.closed:
            raise MotorBusError("in-process link is closed")
        with link._lock:
            if link._command is not None:
                link.dropped_commands += 1
            link._command = (command.copy(), self._last_feedback_seq)
            if link.waiting:
                link._cv.notify_all()

    def receive(self, timeout_s: float | None = 0.0) -> MotorFeedback | None:
        link = self.link
        with link._lock:
            if link._feedback is None and (timeout_s is None or timeout_s > 0):
                deadline = None if timeout_s is None else time.monotonic() + timeout_s
                link.waiting += 1
                try:
                    while link._feedback is None:
                        remaining = None if deadline is None else deadline - time.monotonic()
                        if remaining is not None and remaining <= 0:
                            break
                        link._cv.wait(remaining)
                finally:
                    link.waiting -= 1
            fb, link._feedback = link._feedback, None
        if fb is not None:
            self._last_feedback_seq = fb.seq
        return fb

    def shutdown(self) -> None:
        self.link.closed = True
