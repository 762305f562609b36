"""`sparc-quad spine-cmd`: send spine commands (mode, target, gains, E-stop, reset) over LCM, paced.

    sparc-quad spine-cmd --mode impedance --kx 400 --rate 50 --duration 5
    sparc-quad spine-cmd --mode estop
"""

from __future__ import annotations

import argparse
import json
import math
import time
from collections.abc import Callable

import numpy as np

from sparc_quad.cli.args import (
    LOOP_RATE_MAX_HZ,
    WALL_DURATION_MAX_S,
    add_gain_options,
    damping,
    finite_float,
    in_range,
    lcm_url,
    loop_rate,
    stiffness,
)
from sparc_quad.cli.errors import BadInput
from sparc_quad.cli.signals import stop_on_signals
from spine_module import params as P
from spine_module.messages import Mode, channels, codec

MODES = [m.name.lower().replace("_", "-") for m in Mode]
_TAU = codec.COMMAND_RANGES["tau_ff"]


def register(sub: argparse._SubParsersAction) -> None:
    c = sub.add_parser("spine-cmd", help="send spine commands (mode, target, gains, E-stop, reset) over LCM",
                       description="Publish sparc.spine_command_t on SPARC_SPINE_COMMAND, as a torso "
                                   "computer does, at --rate for --duration. The node holds the last target "
                                   "with default gains when commands stop for 200 ms, so send at a rate for "
                                   "as long as the command should hold.")
    c.add_argument("--lcm-url", type=lcm_url, default=channels.DEFAULT_URL, help="LCM URL")
    c.add_argument("--mode", choices=MODES, default="impedance",
                   help="the node's mode: " + ", ".join(MODES) + " (estop latches until --reset)")
    c.add_argument("--x-d", type=finite_float, nargs=3, default=list(P.X_EQUILIBRIUM),
                   metavar=("X", "Z", "THETA"),
                   help="target pose: x m, z m, theta rad (the node's ranges apply)")
    add_gain_options(c)
    c.add_argument("--tau-ff", type=in_range(_TAU.lo, _TAU.hi), nargs=3, default=[0.0, 0.0, 0.0],
                   metavar=("T2", "T3", "T4"),
                   help=f"joint feed-forward torques q2..q4, N*m, each {_TAU.lo:g}..{_TAU.hi:g}")
    c.add_argument("--no-friction", action="store_true",
                   help="impedance without eq. (4) friction compensation")
    c.add_argument("--reset", action="store_true", help="ask the node to clear latched faults")
    c.add_argument("--rate", type=loop_rate, default=50.0,
                   help=f"messages per second, up to {LOOP_RATE_MAX_HZ:g}")
    c.add_argument("--duration", type=in_range(0.0, WALL_DURATION_MAX_S), default=0.0,
                   help="seconds to keep sending; 0 sends one message")
    c.set_defaults(func=run)


def pace(rate_hz: float, duration_s: float, send: Callable[[int], None], stop: Callable[[], bool] = bool,
         clock: Callable[[], float] = time.monotonic, sleep: Callable[[float], None] = time.sleep) -> int:
    """Call send(i) at t0 + i / rate_hz for t < t0 + duration_s (once if duration_s is 0); a slot the loop
    is late for is skipped, not sent in a burst, so the run ends on time. Returns the number sent."""
    t0 = clock()
    end = t0 + duration_s
    sent = slot = 0
    while True:
        send(sent)
        sent += 1
        if duration_s <= 0 or stop():
            return sent
        slot = max(slot + 1, math.floor((clock() - t0) * rate_hz) + 1)  # the next slot still ahead
        t_next = t0 + slot / rate_hz
        if t_next >= end:
            return sent
        sleep(max(0.0, t_next - clock()))
        if clock() >= end:
            return sent


def run(args: argparse.Namespace) -> int:
    import lcm

    from spine_module.messages import MessageError, SpineCommand

    mode = Mode[args.mode.upper().replace("-", "_")]
    cmd = SpineCommand(mode=mode, x_d=np.array(args.x_d), k=np.array(stiffness(args)),
                       d=np.array(damping(args)), tau_ff=np.array(args.tau_ff),
                       friction_compensation=not args.no_friction, reset=args.reset)
    try:  # validate before sending: the node would reject it anyway, naming the same field
        codec.decode_command(codec.encode_command(cmd))
    except MessageError as exc:
        raise BadInput(f"not sent: {exc}") from exc
    if mode in (Mode.IMPEDANCE, Mode.PD):  # the node refuses gains its loop would chatter with; it checks at
        # its own --rate, this at the node's default (the fastest: the least strict)
        from spine_module.control.gain_limits import unstable_gains
        from spine_module.params import CONTROL_RATE_HZ

        why = unstable_gains(cmd.k, cmd.d, CONTROL_RATE_HZ)
        if why is not None:
            raise BadInput(f"not sent: SPARC_SPINE_COMMAND.k/d: {why}")
    try:
        lc = lcm.LCM(args.lcm_url)
    except RuntimeError as exc:
        raise BadInput(f"cannot open LCM at {args.lcm_url!r}: {exc}") from exc

    def send(i: int) -> None:
        cmd.seq, cmd.stamp_s = i, time.time()
        lc.publish(channels.SPINE_COMMAND, codec.encode_command(cmd))

    with stop_on_signals() as stop:
        n = pace(args.rate, args.duration, send, stop.is_set)
    print(json.dumps({"sent": n, "mode": cmd.mode.name}))
    return stop.exit_code()
