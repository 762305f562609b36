"""The node's two clocks.

`RealTimeClock`: a fixed-rate loop on the monotonic clock; `wait()` sleeps to the next deadline (coarse
sleep, then a short spin) and measures the achieved period. Overruns are counted, not made up in a burst.

Lockstep has no clock object: its time is the stamp of the motor feedback tick being answered, so a
co-simulation runs one control step per feedback tick, deterministically, at whatever speed the machine
manages (see `runner.run_lockstep`).
"""

from __future__ import annotations

import time
from collections import deque


class PeriodStats:
    """Measured periods: last, and the max |period - nominal| over a window of ticks (jitter), kept in
    O(1) per tick with a monotonic deque."""

    def __init__(self, nominal_s: float, window: int = 1000) -> None:
        self.nominal = nominal_s
        self.window = window
        self._maxq: deque[tuple[int, float]] = deque()  # (tick, deviation), deviations decreasing
        self.last_wall: float | None = None
        self.period = 0.0
        self.ticks = 0

    def mark(self, wall_s: float) -> None:
        if self.last_wall is not None:
            self.period = wall_s - self.last_wall
            dev = abs(self.period - self.nominal)
            q = self._maxq
            while q and q[-1][1] <= dev:
                q.pop()
            q.append((self.ticks, dev))
            while q[0][0] <= self.ticks - self.window:
                q.popleft()
        self.last_wall = wall_s
        self.ticks += 1

    @property
    def jitter_max(self) -> float:
        return self._maxq[0][1] if self._maxq else 0.0


class RealTimeClock:
    def __init__(self, rate_hz: float, spin_s: float = 0.0002) -> None:
        self.period = 1.0 / rate_hz
        self.spin_s = spin_s
        self.t0 = time.monotonic()
        self._next = self.t0
        self.overruns = 0

    def wait(self) -> float:
        """Sleep until the next tick; return the time since start, s."""
        self._next += self.period
        while True:
            remaining = self._next - time.monotonic()
            if remaining <= 0:
                break
            if remaining > self.spin_s:
                time.sleep(remaining - self.spin_s)
        now = time.monotonic()
        if now - self._next > 5 * self.period:  # fell far behind: re-phase instead of bursting
            self.overruns += 1
            self._next = now
        return now - self.t0
