"""A controller's call clock as the SPARC authors' MuJoCo loop keeps it.

Their loop (github YueWang996/sparc d9639f5, `mujoco_simulation/main_robot.py`, MIT, Copyright (c) 2026
YueWang996) calls the controller when `time - last_call >= period`, `time` being MuJoCo's float clock
(`data.time += timestep` each step) and `last_call` the time of the previous call, starting at 0. With a
1 ms step and a 5 ms period the float sums make that every 5 or 6 steps (~182 Hz, not 200 Hz), and the
first call is at 5 ms: torques are zero before it and held between calls. The gait and the spine drive
each keep one of these; fed the same step they agree call for call.
"""

from __future__ import annotations


class ControlClock:
    """`tick()` once per physics step, before the step: True when the controller runs at this step."""

    def __init__(self, period_s: float, dt_s: float) -> None:
        if not (period_s > 0 and dt_s > 0):
            raise ValueError(f"control period and step must be > 0 s, got {period_s}, {dt_s}")
        self.period_s, self.dt_s = float(period_s), float(dt_s)
        self.now_s = 0.0  # the float clock at this step (as MuJoCo accumulates it)
        self.last_call_s = 0.0
        self.calls = 0
        self._next_now = 0.0

    def tick(self) -> bool:
        """Advance to this step's time; whether the controller is called now."""
        self.now_s = self._next_now
        self._next_now = self.now_s + self.dt_s
        if self.now_s - self.last_call_s >= self.period_s:
            self.last_call_s = self.now_s
            self.calls += 1
            return True
        return False

    def idle_ticks(self) -> int:
        """How many of the next `tick()`s will not call the controller (the same float sums, nothing
        advanced): a loop steps that many held steps in one go."""
        now, k = self._next_now, 0
        while now - self.last_call_s < self.period_s:
            now += self.dt_s
            k += 1
        return k
