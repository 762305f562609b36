"""Argument types and option groups shared by the subcommands: one spelling and one check per number.

Every numeric option is checked where it is parsed (finite, sign, range), so a bad value ends in
argparse's usage line and exit 2 naming the option, never in a traceback or a silent spin. Option groups
(spine gains, CAN bus) are defined once here and used by every command that takes them.
"""

from __future__ import annotations

import argparse
import math
import os
import re
import tempfile
from collections.abc import Callable, Sequence
from pathlib import Path

from sparc_quad.limits import SEED_MAX, SIM_DURATION_MAX_S
from spine_module import params as P
from spine_module.messages import codec

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


# ---- limits of what a run can do (each with its reason) ----
LOOP_RATE_MAX_HZ = P.CONTROL_RATE_HZ  # a Python loop paced by the monotonic clock keeps 1 kHz, not more
NODE_RATE_MIN_HZ = 100.0  # the node's deadlines (torso stale 20 ms) need a tick at least every 10 ms
WALL_DURATION_MAX_S = 7 * 86400.0  # runs that keep no log (node, emulator, watchdog, spine-cmd): a week
WAIT_MAX_S = 3600.0  # waits for a peer or a reply
SPIN_MAX_US = 100_000.0  # a lockstep poll longer than 0.1 s is a busy loop, not a wait


positive_float = in_range(0.0, lo_open=True)
nonnegative_float = in_range(0.0)
positive_int = in_range(1, kind=int)
nonnegative_int = in_range(0, kind=int)
fraction_open = in_range(0.0, 1.0, lo_open=True, hi_open=True)  # strictly between 0 and 1
seed = in_range(0, SEED_MAX, kind=int)
sim_duration = in_range(0.0, SIM_DURATION_MAX_S, lo_open=True)
wall_duration = in_range(0.0, WALL_DURATION_MAX_S, lo_open=True)
wait_s = in_range(0.0, WAIT_MAX_S, lo_open=True)
loop_rate = in_range(0.0, LOOP_RATE_MAX_HZ, lo_open=True)
node_rate = in_range(NODE_RATE_MIN_HZ, LOOP_RATE_MAX_HZ)
spin_us = in_range(0.0, SPIN_MAX_US)


def add_spin_option(p: argparse.ArgumentParser, flag: str = "--spin-us") -> None:
    """The lockstep poll-before-block option (`spine_module.buses.lcm.handle`), one spelling everywhere."""
    p.add_argument(flag, type=spin_us, default=0.0, metavar="US",
                   help="lockstep over LCM: poll for the peer's next message for up to this many "
                        "microseconds before blocking. On CPUs of their own, 1000 saves the wake-up each "
                        "message costs a blocked wait (15 %% faster measured on a VM); where other work "
                        "competes for the CPUs it is much slower (4.3x measured). At most "
                        f"{SPIN_MAX_US:g} (default: %(default)s, block at once)")


WAKE_LATENCY_MAX_US = 1_000_000


def wake_latency_us(text: str) -> int | None:
    """A CPU wake-latency bound in us, or `off` (None: nothing is requested)."""
    if text.strip().lower() == "off":
        return None
    return int(in_range(0, WAKE_LATENCY_MAX_US, kind=int)(text))


def add_wake_latency_option(p: argparse.ArgumentParser, flag: str = "--wake-latency-us",
                            when: str = "", default: int | None = None) -> None:
    """The PM QoS wake-latency request (`spine_module.node.realtime.hold_wake_latency`), one spelling.
    `default` None: off (nothing requested: a simulation holds no CPU out of deep idle unless asked)."""
    p.add_argument(flag, type=wake_latency_us, default=default, metavar="US|off",
                   help=f"{when}while this process runs, keep every CPU's idle wake-up within this many "
                        "microseconds (Linux PM QoS, /dev/cpu_dma_latency; needs root, else skipped with a "
                        "warning): an idle CPU then polls instead of halting, so a message for a waiting "
                        f"peer is taken at once. 0..{WAKE_LATENCY_MAX_US}, or off "
                        f"(default: {'off' if default is None else default})")


def nonempty(text: str) -> str:
    if not text.strip():
        raise argparse.ArgumentTypeError("must not be empty")
    return text


def regex(text: str) -> str:
    """A non-empty regular expression that compiles (as LCM's channel subscriptions use)."""
    nonempty(text)
    try:
        re.compile(text)
    except re.error as exc:
        raise argparse.ArgumentTypeError(f"not a regular expression ({exc}): {text!r}") from None
    return text


LCM_SCHEMES = ("udpm", "mpudpm", "memq", "file", "tcpq")


def lcm_url(text: str) -> str:
    """An LCM provider URL: udpm://239.255.76.67:7667?ttl=0, memq://, file:///path?mode=r, ..."""
    scheme, sep, _ = text.partition("://")
    if not sep or scheme not in LCM_SCHEMES:
        raise argparse.ArgumentTypeError(
            f"expected an LCM URL (scheme {', '.join(LCM_SCHEMES)}), e.g. udpm://239.255.76.67:7667?ttl=0, "
            f"got {text!r}")
    return text


def id_list(lo: int, hi: int) -> Parse:
    """Comma-separated distinct integers in [lo, hi], decimal or 0x-hex (e.g. motor ids 1,2,3)."""

    def parse(text: str) -> list[int]:
        out: list[int] = []
        for t in (t.strip() for t in text.split(",")):
            try:
                out.append(int(t, 0))
            except ValueError:
                raise argparse.ArgumentTypeError(
                    f"expected comma-separated integers in [{lo}, {hi}], got {text!r}") from None
        bad = [i for i in out if not lo <= i <= hi]
        if bad:
            raise argparse.ArgumentTypeError(f"must be in [{lo}, {hi}], got {bad[0]} in {text!r}")
        if len(set(out)) != len(out):
            raise argparse.ArgumentTypeError(f"an id is repeated in {text!r}")
        return out

    parse.__name__ = f"integers in [{lo}, {hi}]"
    return parse


# ---- paths: checked while parsing, before any work starts ----

def _check_writable(path: Path, what: str) -> None:
    """`path`'s nearest existing ancestor is a folder this process can create files in."""
    anc = path.absolute()
    while not anc.exists():
        anc = anc.parent
    if not anc.is_dir():
        raise argparse.ArgumentTypeError(f"{what} {path}: {anc} is a file, not a folder")
    try:
        fd, probe = tempfile.mkstemp(dir=anc, prefix=".sparc-quad-probe-")
        os.close(fd)
        os.unlink(probe)
    except OSError as exc:
        raise argparse.ArgumentTypeError(f"{what} {path}: cannot write in {anc} "
                                         f"({exc.strerror or exc})") from None


def existing_file(text: str) -> Path:
    """An input file that exists."""
    path = Path(text)
    if not path.is_file():
        raise argparse.ArgumentTypeError(f"{path}: no such file")
    return path


def existing_dir(what: str = "") -> Callable[[str], Path]:
    """An input folder that exists (`what` says which, in the error)."""

    def parse(text: str) -> Path:
        path = Path(text)
        if not path.is_dir():
            raise argparse.ArgumentTypeError(f"{path}: no such folder{f' ({what})' if what else ''}")
        return path

    parse.__name__ = "folder"
    return parse


def output_dir(text: str) -> Path:
    """A folder to write into: not empty, not a file, creatable and writable."""
    if not text.strip():
        raise argparse.ArgumentTypeError("must name a folder (an empty path would write into the current "
                                         "folder)")
    path = Path(text)
    if path.exists() and not path.is_dir():
        raise argparse.ArgumentTypeError(f"{path} exists and is not a folder")
    _check_writable(path, "folder")
    return path


def output_file(suffixes: Sequence[str] | None = None) -> Callable[[str], Path]:
    """A file to write: not empty, not a folder, its folder creatable and writable, one of `suffixes`."""

    def parse(text: str) -> Path:
        if not text.strip():
            raise argparse.ArgumentTypeError("must name a file")
        path = Path(text)
        if path.is_dir():
            raise argparse.ArgumentTypeError(f"{path} is a folder")
        if suffixes is not None:
            suffix = "".join(path.suffixes[-2:]) if path.suffix == ".gz" else path.suffix
            base = suffix.removesuffix(".gz")
            if base.lower() not in suffixes:
                raise argparse.ArgumentTypeError(f"{path}: unknown extension {suffix or '(none)'!r}; "
                                                 f"one of {', '.join(suffixes)}")
        _check_writable(path.parent, "file")
        return path

    parse.__name__ = "file path"
    return parse


# python-can's log writers by extension (can.Logger; each may end in .gz), as the can package lists them
CAN_LOG_SUFFIXES = (".asc", ".blf", ".csv", ".db", ".log", ".mf4", ".trc", ".txt")


LIST_MAX = 100  # values in one swept option: each is a whole experiment


def number_list(item: Parse = finite_float, max_len: int = LIST_MAX) -> Parse:
    """Comma-separated numbers, each checked by `item`, as a tuple (e.g. `--kx 300,400,500`); a leading
    minus is a number (`--kx -5,300` reaches the range check, see parser.Parser)."""

    def parse(text: str) -> tuple[float, ...]:
        parts = [t.strip() for t in text.split(",")]
        if not parts or any(not t for t in parts):
            raise argparse.ArgumentTypeError(f"expected comma-separated numbers, got {text!r}")
        if len(parts) > max_len:
            raise argparse.ArgumentTypeError(f"at most {max_len} values, got {len(parts)}")
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

# name -> (what, unit, default, largest value the node accepts: codec.K_MAX / D_MAX)
GAIN_OPTIONS: dict[str, tuple[str, str, float, float]] = {
    "kx": ("stiffness along x", "N/m", float(P.K_DEFAULT[0]), codec.K_MAX[0]),
    "kz": ("stiffness along z", "N/m", float(P.K_DEFAULT[1]), codec.K_MAX[1]),
    "kth": ("stiffness in pitch theta", "N*m/rad", float(P.K_DEFAULT[2]), codec.K_MAX[2]),
    "dx": ("damping along x", "N*s/m", float(P.D_DEFAULT[0]), codec.D_MAX[0]),
    "dz": ("damping along z", "N*s/m", float(P.D_DEFAULT[1]), codec.D_MAX[1]),
    "dth": ("damping in pitch theta", "N*m*s/rad", float(P.D_DEFAULT[2]), codec.D_MAX[2]),
}


def add_gain_options(parser: argparse.ArgumentParser | argparse._ArgumentGroup,
                     names: Sequence[str] = tuple(GAIN_OPTIONS), *, sweep: Sequence[str] = (),
                     defaults: dict[str, object] | None = None, prefix: str = "") -> None:
    """Add the spine-gain options `names` (each in [0, the node's limit]); those in `sweep` take
    comma-separated lists.

    Defaults come from params.py (`K_DEFAULT`, `D_DEFAULT`) unless `defaults` names another params value.
    `prefix` goes in front of each help text (e.g. "static: ").
    """
    defaults = defaults or {}
    for name in names:
        what, unit, default, top = GAIN_OPTIONS[name]
        value = defaults.get(name, default)
        item = in_range(0.0, top)
        if name in sweep:
            value = tuple(float(v) for v in value) if isinstance(value, Sequence) else (float(value),)  # type: ignore[arg-type]
            parser.add_argument(f"--{name}", type=number_list(item), default=value,
                                metavar="V[,V...]",
                                help=f"{prefix}spine {what}, {unit}, 0..{top:g}; comma-separated values "
                                     "are swept")
        else:
            parser.add_argument(f"--{name}", type=item, default=float(value),  # type: ignore[arg-type]
                                help=f"{prefix}spine {what}, {unit}, 0..{top:g}")


def stiffness(args: argparse.Namespace) -> tuple[float, float, float]:
    """(k_x N/m, k_z N/m, k_theta N*m/rad) from --kx --kz --kth."""
    return (args.kx, args.kz, args.kth)


def damping(args: argparse.Namespace) -> tuple[float, float, float]:
    """(d_x N*s/m, d_z N*s/m, d_theta N*m*s/rad) from --dx --dz --dth."""
    return (args.dx, args.dz, args.dth)


# ---- CyberGear CAN bus: one spelling on `motors` and `spine-node --motors can` ----

CAN_BITRATE_MIN, CAN_BITRATE_MAX = 10_000, 1_000_000  # bit/s; CyberGear: 1 Mbit/s


def add_can_options(parser: argparse.ArgumentParser) -> None:
    """--can-interface --can-channel --can-bitrate --can-log --motor-config, as python-can names them."""
    g = parser.add_argument_group("CyberGear motors on CAN")
    g.add_argument("--can-interface", type=nonempty, default="socketcan",
                   help="python-can interface: socketcan, pcan, slcan, gs_usb, virtual, udp_multicast, ...")
    g.add_argument("--can-channel", type=nonempty, default="can0", help="python-can channel")
    g.add_argument("--can-bitrate", type=in_range(CAN_BITRATE_MIN, CAN_BITRATE_MAX, kind=int), default=None,
                   help=f"CAN bit rate, bit/s, {CAN_BITRATE_MIN}..{CAN_BITRATE_MAX} (classic CAN) "
                        "(default: the motor config's)")
    g.add_argument("--can-log", type=output_file(CAN_LOG_SUFFIXES), default=None, metavar="PATH",
                   help=f"log every frame of the session with python-can ({', '.join(CAN_LOG_SUFFIXES)}, "
                        "each optionally .gz)")
    g.add_argument("--motor-config", type=Path, default=None, metavar="TOML",
                   help="per-joint CyberGear config (default: the packaged motors.toml)")
    g.add_argument("--can-option", type=can_option, action="append", default=[], metavar="KEY=VALUE",
                   help="an interface's own python-can option, repeatable, as `can.Bus(**options)` takes it "
                        "(socketcand: --can-option host=10.0.0.2 --can-option port=29536; integers, "
                        "numbers and true/false are converted)")


def can_option(text: str) -> tuple[str, object]:
    """KEY=VALUE for python-can's `can.Bus(**kwargs)`: the value as an int, float or bool when it reads as
    one, else the text."""
    key, sep, value = text.partition("=")
    if not sep or not key.strip().isidentifier():
        raise argparse.ArgumentTypeError(f"expected KEY=VALUE with a Python name as KEY, got {text!r}")
    if key.strip() in ("interface", "channel", "bitrate"):
        raise argparse.ArgumentTypeError(f"{key.strip()} has its own option (--can-{key.strip()})")
    out: object = value
    for conv in (int, float):
        try:
            out = conv(value)
            break
        except ValueError:
            continue
    if value.lower() in ("true", "false"):
        out = value.lower() == "true"
    return key.strip(), out


def can_options(args: argparse.Namespace) -> dict[str, object]:
    """The CAN options as keyword arguments of the CAN backend's `make_bus` (see buses.registry)."""
    return {"interface": args.can_interface, "channel": args.can_channel, "bitrate": args.can_bitrate,
            "log_path": None if args.can_log is None else str(args.can_log), "config_path": args.motor_config,
            "bus_options": dict(args.can_option)}
