"""Argument types and option groups shared by the subcommands: one spelling and one check per number.

Every numeric option is checked where it is parsed (finite, sign, range), so a bad value ends in
argparse's usage line and exit 2 naming the option, never in a traceback or a silent spin. Option groups
(spine gains, CAN bus) are defined once here and used by every command that takes them.
"""

from __future__ import annotations

import argparse
import math
from collections.abc import Callable, Sequence
from pathlib import Path

from spine_module import params as P

Parse = Callable[[str], float]


def _number(text: str, kind: type = float) -> float:
    try:
        value = kind(text)
    except (TypeError, ValueError):
        raise argparse.ArgumentTypeError(
            f"expected {'an integer' if kind is int else 'a number'}, got {text!r}") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"must be finite, got {text!r}")
    return value


def finite_float(text: str) -> float:
    """Any finite number (nan and inf are refused)."""
    return _number(text)


def in_range(lo: float | None = None, hi: float | None = None, *, lo_open: bool = False,
             hi_open: bool = False, kind: type = float) -> Parse:
    """A parser for finite numbers in [lo, hi] (an end is open with `lo_open`/`hi_open`, absent if None)."""
    left = "(" if lo_open else "["
    right = ")" if hi_open else "]"
    span = f"{left}{'-inf' if lo is None else lo}, {'inf' if hi is None else hi}{right}"

    def parse(text: str) -> float:
        value = _number(text, kind)
        if (lo is not None and (value < lo or (lo_open and value == lo))) or \
           (hi is not None and (value > hi or (hi_open and value == hi))):
            raise argparse.ArgumentTypeError(f"must be in {span}, got {text!r}")
        return value

    parse.__name__ = f"number in {span}"  # argparse names the type in its messages
    return parse


positive_float = in_range(0.0, lo_open=True)
nonnegative_float = in_range(0.0)
positive_int = in_range(1, kind=int)
nonnegative_int = in_range(0, kind=int)
fraction_open = in_range(0.0, 1.0, lo_open=True, hi_open=True)  # strictly between 0 and 1


def number_list(item: Parse = finite_float) -> Parse:
    """Comma-separated numbers, each checked by `item`, as a tuple (e.g. `--kx 300,400,500`)."""

    def parse(text: str) -> tuple[float, ...]:
        parts = [t.strip() for t in text.split(",")]
        if not parts or any(not t for t in parts):
            raise argparse.ArgumentTypeError(f"expected comma-separated numbers, got {text!r}")
        out = []
        for t in parts:
            try:
                out.append(item(t))
            except argparse.ArgumentTypeError as exc:
                raise argparse.ArgumentTypeError(
                    f"expected comma-separated numbers, got {text!r}: {exc}") from None
        return tuple(out)

    parse.__name__ = "comma-separated numbers"
    return parse


# ---- spine gains: --kx --kz --kth (N/m, N/m, N*m/rad), --dx --dz --dth (N*s/m, N*s/m, N*m*s/rad) ----

GAIN_OPTIONS: dict[str, tuple[str, str, float]] = {
    "kx": ("stiffness along x", "N/m", float(P.K_DEFAULT[0])),
    "kz": ("stiffness along z", "N/m", float(P.K_DEFAULT[1])),
    "kth": ("stiffness in pitch theta", "N*m/rad", float(P.K_DEFAULT[2])),
    "dx": ("damping along x", "N*s/m", float(P.D_DEFAULT[0])),
    "dz": ("damping along z", "N*s/m", float(P.D_DEFAULT[1])),
    "dth": ("damping in pitch theta", "N*m*s/rad", float(P.D_DEFAULT[2])),
}


def add_gain_options(parser: argparse.ArgumentParser | argparse._ArgumentGroup,
                     names: Sequence[str] = tuple(GAIN_OPTIONS), *, sweep: Sequence[str] = (),
                     defaults: dict[str, object] | None = None, prefix: str = "") -> None:
    """Add the spine-gain options `names` (each >= 0, finite); those in `sweep` take comma-separated lists.

    Defaults come from params.py (`K_DEFAULT`, `D_DEFAULT`) unless `defaults` names another params value.
    `prefix` goes in front of each help text (e.g. "static: ").
    """
    defaults = defaults or {}
    for name in names:
        what, unit, default = GAIN_OPTIONS[name]
        value = defaults.get(name, default)
        if name in sweep:
            value = tuple(float(v) for v in value) if isinstance(value, Sequence) else (float(value),)  # type: ignore[arg-type]
            parser.add_argument(f"--{name}", type=number_list(nonnegative_float), default=value,
                                metavar="V[,V...]",
                                help=f"{prefix}spine {what}, {unit}; comma-separated values are swept "
                                     f"(default: {','.join(f'{v:g}' for v in value)})")
        else:
            parser.add_argument(f"--{name}", type=nonnegative_float, default=float(value),  # type: ignore[arg-type]
                                help=f"{prefix}spine {what}, {unit} (default: %(default)s)")


def stiffness(args: argparse.Namespace) -> tuple[float, float, float]:
    """(k_x N/m, k_z N/m, k_theta N*m/rad) from --kx --kz --kth."""
    return (args.kx, args.kz, args.kth)


def damping(args: argparse.Namespace) -> tuple[float, float, float]:
    """(d_x N*s/m, d_z N*s/m, d_theta N*m*s/rad) from --dx --dz --dth."""
    return (args.dx, args.dz, args.dth)


# ---- CyberGear CAN bus: one spelling on `motors` and `spine-node --motors can` ----

def add_can_options(parser: argparse.ArgumentParser) -> None:
    """--can-interface --can-channel --can-bitrate --can-log --motor-config, as python-can names them."""
    g = parser.add_argument_group("CyberGear motors on CAN")
    g.add_argument("--can-interface", default="socketcan",
                   help="python-can interface: socketcan, pcan, slcan, gs_usb, virtual, udp_multicast, ... "
                        "(default: %(default)s)")
    g.add_argument("--can-channel", default="can0", help="python-can channel (default: %(default)s)")
    g.add_argument("--can-bitrate", type=positive_int, default=None,
                   help="CAN bit rate, bit/s (default: the motor config's)")
    g.add_argument("--can-log", default=None, metavar="PATH",
                   help="log every frame of the session with python-can (.asc, .blf, .log, .csv)")
    g.add_argument("--motor-config", type=Path, default=None, metavar="TOML",
                   help="per-joint CyberGear config (default: the packaged motors.toml)")


def can_options(args: argparse.Namespace) -> dict[str, object]:
    """The CAN options as keyword arguments of the CAN backend's `make_bus` (see buses.registry)."""
    return {"interface": args.can_interface, "channel": args.can_channel, "bitrate": args.can_bitrate,
            "log_path": args.can_log, "config_path": args.motor_config}
