"""Registry entry for `spine-node --motors can` (see `spine_module.buses.registry`).

`make_bus` opens the python-can bus and builds `CanMotorBus` from the per-joint config file; the node then
calls `start()`, the handshake (a motor that does not answer raises MotorBusError naming it, after stop
frames went out), and `stop()`/`shutdown()` when it ends. The command-line spelling of these options is
`sparc_quad.cli.args.add_can_options`.
"""

from __future__ import annotations

from pathlib import Path

from spine_module.buses.cybergear.config import ConfigError, load_config
from spine_module.buses.cybergear.driver import CanMotorBus


def make_bus(*, lc=None, config_path: str | Path | None = None, interface: str = "socketcan",
             channel: str = "can0", bitrate: int | None = None,
             log_path: str | Path | None = None, rate_hz: float | None = None,
             bus_options: dict | None = None) -> CanMotorBus:
    """CyberGears as `config_path` (default: the packaged motors.toml) describes them, on python-can's
    `interface`/`channel` at `bitrate` bit/s (default: the config's); `log_path` records every frame;
    `bus_options` are the interface's own python-can options (socketcand's host and port).

    `rate_hz`: the node's actual control rate. The config's timeouts (`can_timeout_s`, `silent_timeout_s`:
    at least two control periods) and its bus-load check are judged at this rate, not at the file's
    `rate_hz`, which only stands in for it when no node runs (ConfigError naming the file and the rate)."""
    cfg = load_config(config_path)
    if rate_hz is not None and rate_hz != cfg.rate_hz:
        try:
            cfg = cfg.with_(rate_hz=float(rate_hz))
        except ValueError as e:
            where = config_path if config_path is not None else "the packaged motors.toml"
            raise ConfigError(f"{where}: at the node's --rate {rate_hz:g} Hz: {e}") from None
    return CanMotorBus(cfg, interface=interface, channel=channel, bitrate=bitrate or cfg.bitrate,
                       log_path=log_path, bus_options=bus_options)
