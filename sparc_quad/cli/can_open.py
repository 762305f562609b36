"""Opening a CAN bus, with every failure as one line naming the interface, the channel and the likely
cause (`BadInput`, exit 2) instead of python-can's traceback."""

from __future__ import annotations

import errno

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
    if isinstance(exc, ImportError):
        return f"the {interface} driver is not installed ({exc})"
    return f"{type(exc).__name__}: {exc}"


def bus_open_error(exc: BaseException, interface: str, channel: str) -> BadInput:
    """The BadInput for a bus that did not open."""
    return BadInput(f"cannot open CAN bus {interface}:{channel}: {_cause(exc, interface, channel)}")


def open_errors() -> tuple[type[BaseException], ...]:
    """The exceptions that mean "this bus cannot be opened here" (not a bug in this program)."""
    import can

    return (can.CanError, OSError, ImportError, ValueError)


def open_can(interface: str, channel: str, bitrate: int | None):
    """`driver.open_bus`, failures as BadInput."""
    from spine_module.buses.cybergear.driver import open_bus

    try:
        return open_bus(interface, channel, bitrate)
    except open_errors() as exc:
        raise bus_open_error(exc, interface, channel) from exc
