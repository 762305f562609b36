"""LCM's `handle_timeout`, with a signal's interruption as "nothing dispatched".

LCM returns -1 (the Python binding raises OSError) when a signal interrupts its select(), even a poll with
a zero timeout. In the node and the motor buses a SIGINT or SIGTERM is a stop request that the caller's loop
checks next; raised from a dispatch it ended a node in "internal error", exit 1 (seen: SIGTERM 1.9 s into
start-up, during a lockstep node's feedback receive). Every dispatch in spine_module goes through here.
"""

from __future__ import annotations

import lcm


def dispatch(lc: lcm.LCM, timeout_ms: int) -> int:
    """`lc.handle_timeout(timeout_ms)`: > 0 when a message was dispatched, 0 when none arrived in time or a
    signal interrupted the wait."""
    try:
        return lc.handle_timeout(timeout_ms)
    except OSError:
        return 0
