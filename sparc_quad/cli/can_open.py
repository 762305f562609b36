"""Opening a CAN bus, with every failure as one line naming the interface, the channel and the likely
cause (`BadInput`, exit 2) instead of python-can's traceback."""

from __future__ import annotations

import errno
import logging

from sparc_quad.cli.errors import BadInput


def _cause(exc: BaseException, interface: str, channel: str) -> str:
    import can

    up = f"sudo ip link set {channel} up type can bitrate 1000000"
    if isinstance(exc, can.CanInterfaceNotImplementedError):
        known = ", ".join(sorted(can.interfaces.VALID_INTERFACES))
        return f"python-can has no interface {interface!r} or its driver is not installed ({exc}); " \
               f"interfaces: {known}"
    err = getattr(exc, "errno", None)
    if err is None and isinstance(exc.__cause__ or exc.__context__, OSError):
        err = (exc.__cause__ or exc.__context__).errno  # type: ignore[union-attr]
    if err == errno.EAFNOSUPPORT:
        return "this kernel has no SocketCAN support (AF_CAN); load it (`sudo modprobe can_raw`) or use " \
               "an adapter's own interface (pcan, slcan, gs_usb)"
    if err in (errno.ENODEV, errno.ENXIO):
        return f"there is no CAN device {channel!r} (see `ip link`); bring it up with `{up}`"
    if err == errno.ENETDOWN:
        return f"{channel} is down; bring it up with `{up}`"
    if err in (errno.EPERM, errno.EACCES):
        return f"permission denied ({exc})"
    if isinstance(exc, ImportError | NameError | AttributeError):
        return f"the {interface} driver or its vendor library is not installed ({type(exc).__name__}: {exc})"
    if isinstance(exc, TypeError):
        return f"python-can's {interface} interface needs options this command did not give ({exc}); give " \
               "them with --can-option KEY=VALUE"
    return f"{type(exc).__name__}: {exc}"


def bus_open_error(exc: BaseException, interface: str, channel: str) -> BadInput:
    """The BadInput for a bus that did not open."""
    return BadInput(f"cannot open CAN bus {interface}:{channel}: {_cause(exc, interface, channel)}")


def open_errors() -> tuple[type[BaseException], ...]:
    """The exceptions that mean "this bus cannot be opened here" (not a bug in this program): python-can's
    own, the OS's, and whatever an interface's driver module raises when its vendor library is missing or
    it lacks an option (kvaser: NameError without canlib; socketcand: TypeError without host and port)."""
    import can

    return (can.CanError, OSError, ImportError, ValueError, NameError, TypeError, AttributeError)


class _Once(logging.Filter):
    """Each distinct python-can log message once (socketcand logs its refused connection thousands of times
    a second while it retries)."""

    def __init__(self) -> None:
        super().__init__()
        self.seen: set[str] = set()

    def filter(self, record: logging.LogRecord) -> bool:
        if record.name != "can" and not record.name.startswith("can."):
            return True
        text = record.getMessage()
        if text in self.seen:
            return False
        self.seen.add(text)
        return True


def quiet_repeats() -> None:
    """python-can's log messages each once, from here on."""
    for handler in logging.getLogger().handlers:
        if not any(isinstance(f, _Once) for f in handler.filters):
            handler.addFilter(_Once())


def open_can(interface: str, channel: str, bitrate: int | None, options: dict | None = None):
    """`driver.open_bus`, failures as BadInput."""
    from spine_module.buses.cybergear.driver import open_bus

    quiet_repeats()
    try:
        return open_bus(interface, channel, bitrate, **(options or {}))
    except open_errors() as exc:
        raise bus_open_error(exc, interface, channel) from exc
