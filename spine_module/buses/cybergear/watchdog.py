"""A separate watchdog process for CyberGear motors whose own CAN timeout cannot be set (fallback).

It listens on the same CAN bus as the node and takes the node's command frames as its heartbeat: once the
host has enabled the motors (type 3) or commanded them (types 1, 18), a gap longer than `deadline_s`
without any host -> motor frame means the node is gone (killed, hung, crashed), and the watchdog sends a
stop frame (type 4) to every configured motor, `repeats` times. A stop from the host (type 4) disarms it
until the next enable/command. It sends nothing while the node is alive.

What it covers: the node process dying or hanging (SIGKILL, a deadlock), on any host that shares the CAN
bus; run on a second small computer it also covers a crash of the node's host. It cannot cover a broken
CAN wire between it and the motors: only the motors' own CAN timeout (CAN_TIMEOUT) covers that.
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable, Iterable

import can

from spine_module.buses.cybergear import protocol as P

log = logging.getLogger(__name__)

_RUNNING_TYPES = (P.CommType.ENABLE, P.CommType.OPERATION_CONTROL, P.CommType.PARAM_WRITE)
# deadlines a fallback for the motors' CAN timeout can have: above the 1 ms check period, and no longer
# than the firmware's own longest CAN_TIMEOUT (5 s); a longer one is a watchdog that never fires
DEADLINE_MIN_S = 0.002
DEADLINE_MAX_S = P.CAN_TIMEOUT_MAX_TICKS / P.CAN_TIMEOUT_TICKS_PER_S


class StopWatchdog:
    """Arms on host command frames, fires stop frames after `deadline_s` of silence (see module doc)."""

    def __init__(self, bus: can.BusABC, motor_ids: Iterable[int], host_id: int = P.DEFAULT_HOST_ID,
                 deadline_s: float = 0.05, repeats: int = 3,
                 clock: Callable[[], float] = time.monotonic) -> None:
        if not DEADLINE_MIN_S <= deadline_s <= DEADLINE_MAX_S:
            raise ValueError(f"watchdog deadline must be in [{DEADLINE_MIN_S:g}, {DEADLINE_MAX_S:g}] s, got "
                             f"{deadline_s:g}")
        self.bus, self.ids, self.host_id = bus, tuple(motor_ids), host_id
        self.deadline_s, self.repeats, self.clock = deadline_s, repeats, clock
        self.armed = False
        self.last_host_frame_s: float | None = None
        self.fired: list[tuple[float, float]] = []  # (last host frame s, fired s)
        self._lock = threading.Lock()
        self._sending = False

    def on_message(self, msg: can.Message) -> None:
        """Feed every frame seen on the bus (a can.Notifier listener)."""
        if not msg.is_extended_id or msg.is_error_frame:
            return
        comm, data2, target = P.split_id(msg.arbitration_id)
        if target not in self.ids:
            return  # not host -> one of our motors
        if comm != P.CommType.OPERATION_CONTROL and (data2 & 0xFF) != self.host_id:
            return  # another host's frame (type 1 carries no host id)
        with self._lock:
            if self._sending:
                return  # our own stop frames, echoed back by udp_multicast
            self.last_host_frame_s = self.clock()
            if comm in _RUNNING_TYPES:
                self.armed = True
            elif comm == P.CommType.STOP:
                self.armed = False

    def check(self) -> bool:
        """Fire if armed and the host has been silent past the deadline. Returns True if it fired."""
        with self._lock:
            now = self.clock()
            if not (self.armed and self.last_host_frame_s is not None
                    and now - self.last_host_frame_s > self.deadline_s):
                return False
            self.armed, self._sending = False, True
            last = self.last_host_frame_s
        try:
            for _ in range(self.repeats):
                for i in self.ids:
                    try:
                        self.bus.send(P.encode_stop(i, self.host_id), timeout=0.01)
                    except can.CanError as e:
                        log.error("watchdog: stop frame to motor %d failed: %s", i, e)
        finally:
            with self._lock:
                self._sending = False
        self.fired.append((last, now))
        log.warning("watchdog: no host frame for %.1f ms: stop frames sent to motor(s) %s",
                    (now - last) * 1e3, list(self.ids))
        return True

    def run(self, stop: threading.Event, period_s: float = 0.001) -> None:
        """Check every `period_s` until `stop` is set (the bus must be fed by a Notifier)."""
        while not stop.wait(period_s):
            self.check()


__all__ = ["StopWatchdog"]
