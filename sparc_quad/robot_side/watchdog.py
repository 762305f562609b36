"""The robot's PMU-like watch on the node's heartbeat: a latch, released only by a higher reset_count."""

from __future__ import annotations

import logging
from collections.abc import Iterable

from spine_module import params as P
from spine_module.messages import Heartbeat

log = logging.getLogger("sparc_quad.robot_side")


class HeartbeatWatchdog:
    """When the node's newest heartbeat is older than `deadline_s` the fault latches (the motors get zero
    torque); it clears when heartbeats are fresh again and one carries a higher `reset_count` than when
    it latched. No heartbeat ever seen: not armed (the robot waits for the node before tick 0)."""

    def __init__(self, deadline_s: float = P.SAFETY.heartbeat_deadline_s) -> None:
        self.deadline_s = deadline_s
        self.latched = False
        self.last_s: float | None = None
        self.reset_count = 0
        self._latched_at_reset_count = 0

    def update(self, heartbeats: Iterable[Heartbeat], clock_s: float) -> bool:
        for hb in heartbeats:
            self.last_s = clock_s
            self.reset_count = max(self.reset_count, hb.reset_count)
        if self.last_s is None:
            return self.latched
        fresh = clock_s - self.last_s <= self.deadline_s
        if self.latched and fresh and self.reset_count > self._latched_at_reset_count:
            self.latched = False
            log.warning("t=%.4f s: node heartbeat back and reset requested: fault cleared", clock_s)
        if not self.latched and not fresh:
            self.latched = True
            self._latched_at_reset_count = self.reset_count
            log.warning("t=%.4f s: node heartbeat lost (%.1f ms): fault latched, zero torque", clock_s,
                        1e3 * (clock_s - self.last_s))
        return self.latched
