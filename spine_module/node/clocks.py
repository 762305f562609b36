"""The node's two clocks.

`RealTimeClock`: a fixed-rate loop on the monotonic clock; `wait()` sleeps to the next deadline (coarse
sleep, then a short spin) on an absolute schedule. A tick more than one period late counts as an overrun;
more than five periods behind, the clock re-phases instead of making the time up in a burst.
`PeriodStats` keeps the measured periods (jitter window, and a histogram for the run summary).

Lockstep has no clock object: its time is the stamp of the motor feedback tick being answered, so a
co-simulation runs one control step per feedback tick, deterministically, at whatever speed the machine
manages (see `runner.run_lockstep`).
"""

from __future__ import annotations

import math
import time
from collections import deque


class PeriodHistogram:
    """Every measured tick period of a run in fixed 1 us bins (O(1) per tick, bounded memory), for the
    run summary's percentiles; periods beyond `max_s` land in one overflow bin (their max is kept)."""

    def __init__(self, nominal_s: float, max_s: float | None = None, bin_s: float = 1e-6) -> None:
        self.nominal = nominal_s
        self.bin_s = bin_s
        self._inv = 1.0 / bin_s
        self.n_bins = math.ceil((max_s if max_s is not None else 20 * nominal_s) / bin_s)
        self.counts = [0] * (self.n_bins + 1)
        self.n = 0
        self.max_s = 0.0
        self.over_1_5x = 0  # periods longer than 1.5 nominal: a late tick

    def add(self, period_s: float) -> None:
        i = int(period_s * self._inv)
        self.counts[i if 0 <= i < self.n_bins else self.n_bins] += 1
        self.n += 1
        if period_s > self.max_s:
            self.max_s = period_s
        if period_s > 1.5 * self.nominal:
            self.over_1_5x += 1

    def percentile(self, p: float) -> float:
        """Upper edge of the bin holding the p-th percentile (p in 0..100), s; NaN if empty."""
        if self.n == 0:
            return math.nan
        target = max(1, math.ceil(p * self.n / 100.0 - 1e-9))  # 99.9 % of 1000 is the 999th, not 1000th
        run = 0
        for i, c in enumerate(self.counts):
            run += c
            if run >= target:
                return self.max_s if i == self.n_bins else min((i + 1) * self.bin_s, self.max_s)
        return self.max_s

    def summary(self) -> dict[str, float | int]:
        """p50/p99/p99.9/max of the tick period in microseconds, and the count of late ticks."""
        us = 1e6
        return {"ticks_measured": self.n, "nominal_us": round(self.nominal * us, 3),
                "p50_us": round(self.percentile(50) * us, 3), "p99_us": round(self.percentile(99) * us, 3),
                "p99_9_us": round(self.percentile(99.9) * us, 3), "max_us": round(self.max_s * us, 3),
                "over_1_5x_nominal": self.over_1_5x}


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
        self.histogram = PeriodHistogram(nominal_s)

    def mark(self, wall_s: float) -> None:
        if self.last_wall is not None:
            self.period = wall_s - self.last_wall
            self.histogram.add(self.period)
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
        self.overruns = 0  # ticks that began more than one period after their deadline (a lost slot)
        self.rephases = 0  # times the clock fell more than 5 periods behind and re-phased

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
        late = now - self._next
        if late > self.period:
            self.overruns += 1
        if late > 5 * self.period:  # fell far behind: re-phase instead of bursting
            self.rephases += 1
            self._next = now
        return now - self.t0
