"""Publish a marker on an LCM channel until `lcm-logger` has written it to its log: run before a session
(the logger is subscribed) and after it (everything published before the marker has been received, since
one socket delivers in order), so a test waits on the logger instead of guessing how long it needs.

    python -m tests.lcm_mark URL CHANNEL LOGFILE [TIMEOUT_S]
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import lcm

START, END = "SPARC_TEST_MARK_START", "SPARC_TEST_MARK_END"  # channels a recorded session's reader skips


def main(url: str, channel: str, logfile: str, timeout_s: float = 60.0) -> int:
    lc = lcm.LCM(url)
    log, needle = Path(logfile), channel.encode()
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        lc.publish(channel, b"mark")
        if log.exists() and needle in log.read_bytes():  # written within the logger's flush interval
            return 0
        time.sleep(0.02)
    print(f"lcm-logger did not record {channel} within {timeout_s:g} s", file=sys.stderr)
    return 1


if __name__ == "__main__":
    sys.exit(main(sys.argv[1], sys.argv[2], sys.argv[3], *map(float, sys.argv[4:5])))
