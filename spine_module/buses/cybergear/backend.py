"""Registry entry for `spine-node --motors can` (see `spine_module.buses.registry`).

`make_bus` opens the python-can bus and builds `CanMotorBus` from the per-joint config file; the node then
calls `start()`, the handshake (a motor that does not answer raises MotorBusError naming it, after stop
frames went out), and `stop()`/`shutdown()` when it ends. The command-line spelling of these options is
`sparc_quad.cli.args.add_can_options`.
"""

from __future__ import annotations

from pathlib import Path

from spine_module.buses.cybergear.config import load_config
from spine_module.buses.cybergear.driver import CanMotorBus


def make_bus(*, lc=None, config_path: str | Path | None = None, interface: str = "socketcan",
             channel: str = "can0", bitrate: int | None = None,
             log_path: str | Path | None = None) -> CanMotorBus:
    """CyberGears as `config_path` (default: the packaged motors.toml) describes them, on python-can's
    `interface`/`channel` at `bitrate` bit/s (default: the config's); `log_path` records every frame."""
    cfg = load_config(config_path)
    return CanMotorBus(cfg, interface=interface, channel=channel, bitrate=bitrate or cfg.bitrate,
                       log_path=log_path)
