"""One-shot CyberGear operations for people at the bench: scan, status, enable, disable, zero, set id.

A `Session` owns a python-can bus, a notifier that decodes replies, and an optional python-can log of
every frame sent and received.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path

import can

from spine_module.buses.cybergear import protocol as P
from spine_module.buses.cybergear.driver import loggable

# CAN_TIMEOUT last: the motors' own CAN watchdog (0x200C, 1/20000 s per count; see protocol.py) as the
# motor reports it; a firmware that does not answer for it simply leaves it out of the status line
STATUS_PARAMS = ("run_mode", "mechPos", "mechVel", "VBUS", "limit_torque", "limit_cur", "iqf", "CAN_TIMEOUT")


@dataclass
class MotorStatus:
    motor_id: int
    uid: bytes | None = None
    params: dict[str, float | int] = field(default_factory=dict)
    feedback: P.Feedback | None = None
    fault: P.FaultFrame | None = None


class Session:
    """A bus plus reply collection; use as a context manager."""

    def __init__(self, bus: can.BusABC, host_id: int = P.DEFAULT_HOST_ID, ranges: P.Ranges = P.DEFAULT_RANGES,
                 log_path: str | Path | None = None, own_bus: bool = True) -> None:
        self.bus, self.host_id, self.ranges, self.own_bus = bus, host_id, ranges, own_bus
        self.replies: list[P.Frame] = []
        self.cond = threading.Condition()
        self.log = can.Logger(str(log_path)) if log_path else None
        self._log_lock = threading.Lock()
        self.notifier = can.Notifier(bus, [self._on_message], timeout=0.05)

    def _log(self, msg: can.Message) -> None:
        if self.log is not None:
            with self._log_lock:
                self.log.on_message_received(loggable(msg))

    def _on_message(self, msg: can.Message) -> None:
        self._log(msg)
        try:
            frame = P.decode_from_motor(msg, None, None, self.ranges)
        except P.FrameError:
            return
        if frame.host_id not in (self.host_id, 0) and not isinstance(frame, P.DeviceId):
            return
        with self.cond:
            self.replies.append(frame)
            self.cond.notify_all()

    def send(self, msg: can.Message) -> None:
        self.bus.send(msg, timeout=0.1)
        self._log(can.Message(timestamp=time.time(), arbitration_id=msg.arbitration_id, data=msg.data,
                              is_extended_id=True, is_rx=False))

    def collect(self, timeout_s: float, until=None) -> list[P.Frame]:
        """Wait up to timeout_s (or until `until(replies)` is true) and return the replies so far."""
        deadline = time.monotonic() + timeout_s
        with self.cond:
            while not (until is not None and until(self.replies)):
                left = deadline - time.monotonic()
                if left <= 0:
                    break
                self.cond.wait(left)
            return list(self.replies)

    def clear(self) -> None:
        with self.cond:
            self.replies.clear()

    def close(self) -> None:
        self.notifier.stop()
        if self.log is not None:
            with self._log_lock:
                self.log.stop()
                self.log = None
        if self.own_bus:
            self.bus.shutdown()

    def __enter__(self) -> Session:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def scan(s: Session, candidates: Iterable[int] = range(1, 128), timeout_s: float = 0.5) -> dict[int, bytes]:
    """Send get-id to each candidate; returns {motor id: 64-bit uid} of those that answered."""
    s.clear()
    for i in candidates:
        s.send(P.encode_get_id(i, s.host_id))
    return {f.motor_id: f.uid for f in s.collect(timeout_s) if isinstance(f, P.DeviceId)}


def status(s: Session, ids: Iterable[int], timeout_s: float = 0.5) -> dict[int, MotorStatus]:
    """Read-only: uid (type 0) and a few parameters (type 17). Changes nothing on the motor."""
    ids = list(ids)
    s.clear()
    for i in ids:
        s.send(P.encode_get_id(i, s.host_id))
        for name in STATUS_PARAMS:
            s.send(P.encode_param_read(i, name, s.host_id))
    want = len(ids) * (1 + len(STATUS_PARAMS))
    replies = s.collect(timeout_s, until=lambda r: len(r) >= want)
    out = {i: MotorStatus(i) for i in ids}
    for f in replies:
        st = out.get(f.motor_id)
        if st is None:
            continue
        if isinstance(f, P.DeviceId):
            st.uid = f.uid
        elif isinstance(f, P.ParamReadReply) and f.ok:
            st.params[P.PARAM_BY_INDEX[f.index].name] = f.value
        elif isinstance(f, P.FaultFrame):
            st.fault = f
        elif isinstance(f, P.Feedback):
            st.feedback = f
    return out


def command(s: Session, ids: Iterable[int], kind: str, timeout_s: float = 0.5,
            clear_fault: bool = False) -> dict[int, P.Feedback | None]:
    """enable (3), disable (4) or zero (6) each motor; returns each motor's feedback reply (None: silent)."""
    ids = list(ids)
    s.clear()
    for i in ids:
        if kind == "enable":
            s.send(P.encode_enable(i, s.host_id))
        elif kind == "disable":
            s.send(P.encode_stop(i, s.host_id, clear_fault=clear_fault))
        elif kind == "zero":
            s.send(P.encode_set_zero(i, s.host_id))
        else:
            raise ValueError(f"unknown command {kind!r}")

    def done(r):
        return {f.motor_id for f in r if isinstance(f, P.Feedback)} >= set(ids)

    got = {i: None for i in ids}
    for f in s.collect(timeout_s, until=done):
        if isinstance(f, P.Feedback) and f.motor_id in got:
            got[f.motor_id] = f
    return got


def set_id(s: Session, old_id: int, new_id: int, timeout_s: float = 0.5) -> bytes | None:
    """Change a motor's CAN id (type 7); returns the uid the motor answered with from its new id."""
    s.clear()
    s.send(P.encode_set_can_id(old_id, new_id, s.host_id))
    for f in s.collect(timeout_s, until=lambda r: any(isinstance(x, P.DeviceId) and x.motor_id == new_id
                                                      for x in r)):
        if isinstance(f, P.DeviceId) and f.motor_id == new_id:
            return f.uid
    return None
