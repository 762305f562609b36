"""Registry hooks for `spine-node --motors can` (see `spine_module.buses.registry` on the node's side).

`add_arguments` adds the CAN options (prefixed, so they cannot collide with the node's own);
`make_bus` opens the python-can bus and builds `CanMotorBus` from the per-joint config file; the node then
calls `start()`, the handshake (a motor that does not answer raises MotorBusError naming it, after stop
frames went out), and `stop()`/`shutdown()` when it ends.
"""

from __future__ import annotations

import argparse

from spine_module.buses.cybergear.config import DEFAULT_CONFIG_PATH, load_config
from spine_module.buses.cybergear.driver import CanMotorBus


def add_arguments(parser: argparse.ArgumentParser) -> None:
    g = parser.add_argument_group("CyberGear CAN motors (--motors can)")
    g.add_argument("--can-interface", default="socketcan",
                   help="python-can interface: socketcan, pcan, slcan, gs_usb, virtual, udp_multicast, ...")
    g.add_argument("--can-channel", default="can0", help="python-can channel (default: %(default)s)")
    g.add_argument("--can-bitrate", type=int, default=1_000_000, help="bit/s (default: %(default)s)")
    g.add_argument("--motor-config", default=str(DEFAULT_CONFIG_PATH),
                   help="per-joint CyberGear config, TOML (default: the packaged motors.toml)")
    g.add_argument("--can-log", default=None, metavar="PATH",
                   help="log every frame of the session with python-can (.asc, .blf, .log, .csv)")


def make_bus(args: argparse.Namespace, lc=None) -> CanMotorBus:
    cfg = load_config(getattr(args, "motor_config", None))
    return CanMotorBus(cfg, interface=getattr(args, "can_interface", "socketcan"),
                       channel=getattr(args, "can_channel", "can0"),
                       bitrate=getattr(args, "can_bitrate", cfg.bitrate),
                       log_path=getattr(args, "can_log", None))
