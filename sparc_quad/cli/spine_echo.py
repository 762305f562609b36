"""`sparc-quad spine-echo`: print decoded SPARC_* LCM messages, one JSON line each.

    sparc-quad spine-echo --channels 'SPARC_SPINE_.*' --count 10
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from sparc_quad.cli.args import WALL_DURATION_MAX_S, in_range, lcm_url, regex
from sparc_quad.cli.errors import BadInput
from sparc_quad.cli.signals import stop_on_signals
from sparc_quad.jsonfmt import json_text
from spine_module.messages import channels


def register(sub: argparse._SubParsersAction) -> None:
    e = sub.add_parser("spine-echo", help="print decoded SPARC_* LCM messages, one JSON line each",
                       description="Subscribe to the spine interface's channels and print every message, "
                                   "decoded and validated (rejected ones are printed with the reason).")
    e.add_argument("--lcm-url", type=lcm_url, default=channels.DEFAULT_URL, help="LCM URL")
    e.add_argument("--channels", type=regex, default="SPARC_.*", help="channel regular expression")
    e.add_argument("--count", type=in_range(0, 10**12, kind=int), default=0,
                   help="stop after this many messages; 0: never")
    e.add_argument("--timeout", type=in_range(0.0, WALL_DURATION_MAX_S), default=0.0,
                   help="stop after this many seconds; 0: never")
    e.set_defaults(func=run)


def _jsonable(msg) -> dict:
    from dataclasses import asdict, is_dataclass

    if isinstance(msg, tuple):  # (motor command, feedback seq it answers)
        out = _jsonable(msg[0])
        out["feedback_seq"] = msg[1]
        return out
    d = asdict(msg) if is_dataclass(msg) else dict(vars(msg))
    return {k: (v.tolist() if isinstance(v, np.ndarray) else (v.name if hasattr(v, "name") else v))
            for k, v in d.items()}


def echo_line(channel: str, data: bytes) -> dict:
    """One received message as a JSON-able dict: its decoded fields, or why it was rejected."""
    from spine_module.messages import MessageError, decode

    try:
        return {"channel": channel, **_jsonable(decode(channel, data))}
    except MessageError as exc:
        return {"channel": channel, "rejected": str(exc)}
    except Exception as exc:  # a decoder bug must not end the echo: report the packet and go on
        return {"channel": channel, "rejected": f"{type(exc).__name__} while decoding: {exc}"}


def run(args: argparse.Namespace) -> int:
    import lcm

    try:
        lc = lcm.LCM(args.lcm_url)
    except RuntimeError as exc:
        raise BadInput(f"cannot open LCM at {args.lcm_url!r}: {exc}") from exc
    seen = [0]

    def on_message(channel: str, data: bytes) -> None:
        seen[0] += 1
        print(json_text(echo_line(channel, data), default=str), flush=True)

    lc.subscribe(args.channels, on_message)
    deadline = time.monotonic() + args.timeout if args.timeout > 0 else None
    with stop_on_signals() as stop:
        while not stop.is_set() and (args.count <= 0 or seen[0] < args.count):
            if deadline is not None and time.monotonic() > deadline:
                break
            try:
                lc.handle_timeout(100)
            except OSError:  # LCM's select() cut by the signal that set `stop` (EINTR) is the stop
                if not stop.is_set():
                    raise
    return stop.exit_code()
