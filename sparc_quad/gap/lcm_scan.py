"""Check an lcm-logger file's event headers before lcm's C reader sees it.

lcm's reader trusts the header's lengths: an event whose data length is 0x7fffffff crashes the process
(segfault) instead of raising. Each event is: sync word 0xEDA1DA01, event number (int64), timestamp
(int64), channel length (int32), data length (int32), channel, data -- all big-endian. `scan` walks the
headers with plain file reads and returns how many whole, plausible events the file starts with; the
caller hands lcm only those.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass
from pathlib import Path

from sparc_quad.gap.errors import TrialError

SYNC = 0xEDA1DA01
HEADER = struct.Struct(">IqqII")
MAX_CHANNEL_BYTES = 256  # lcm channel names are at most 63 bytes; more is garbage
TAIL_OK_BYTES = 4096  # an unreadable tail this short is an interrupted last write: warned, not fatal


@dataclass
class Scan:
    events: int  # whole, plausible events from the start
    end: int  # byte offset after the last of them
    size: int  # file size
    problem: str | None  # why the scan stopped before the end of the file

    @property
    def unread(self) -> int:
        return self.size - self.end


def scan(path: Path) -> Scan:
    size = path.stat().st_size
    pos = n = 0
    with path.open("rb") as fh:
        while pos < size:
            head = fh.read(HEADER.size)
            if len(head) < HEADER.size:
                return Scan(n, pos, size, f"event {n + 1}: invalid LCM event header at byte {pos}: "
                                          "cut short")
            sync, _num, _ts, clen, dlen = HEADER.unpack(head)
            if sync != SYNC:
                return Scan(n, pos, size, f"event {n + 1}: invalid LCM event header at byte {pos}: "
                                          f"no sync word (0x{sync:08x})")
            if not 0 < clen <= MAX_CHANNEL_BYTES:
                return Scan(n, pos, size, f"event {n + 1}: invalid LCM event header at byte {pos}: "
                                          f"channel length {clen} not in 1..{MAX_CHANNEL_BYTES}")
            end = pos + HEADER.size + clen + dlen
            if dlen >= 2**31 or end > size:
                return Scan(n, pos, size, f"event {n + 1}: invalid LCM event header at byte {pos}: "
                                          f"data length {dlen} runs past the end of the file ({size} bytes)")
            fh.seek(end)
            pos, n = end, n + 1
    return Scan(n, pos, size, None)


def open_checked(path: Path):
    """(lcm.EventLog, number of events to read, unread tail bytes). A bad header before the last
    TAIL_OK_BYTES is a TrialError naming the event and byte; the caller reads exactly that many events."""
    import lcm

    path = Path(path)
    if not path.exists():
        raise TrialError(path, "file not found")
    if path.is_dir():
        raise TrialError(path, "is a directory, not an LCM log")
    if not path.is_file():  # a FIFO would block the scan forever
        raise TrialError(path, "not a regular file (a FIFO, device or socket?), not an LCM log")
    s = scan(path)
    if s.problem and s.unread > TAIL_OK_BYTES:
        raise TrialError(path, f"{s.problem}; {s.unread} bytes after event {s.events} cannot be read")
    if s.events == 0:
        raise TrialError(path, f"no LCM events ({s.problem or 'empty file'})")
    try:
        log = lcm.EventLog(str(path), "r")
    except (OSError, ValueError) as exc:
        raise TrialError(path, f"cannot open LCM log: {exc}") from exc
    return log, s.events, s.unread
