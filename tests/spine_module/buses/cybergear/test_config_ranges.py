"""motors.toml against physics and the CyberGear: every number range-checked, no CAN timeout that reads as
"off" by rounding, the watchdog's deadline bounded, and the hardware ranges kept in one place."""

from __future__ import annotations

import ast
import io
import logging
import math
import re
import struct
import tokenize
import tomllib
from pathlib import Path

import can
import pytest

from spine_module import params
from spine_module.buses.cybergear import CanMotorBus, load_config
from spine_module.buses.cybergear import protocol as P
from spine_module.buses.cybergear.config import DEFAULT_CONFIG_PATH
from spine_module.buses.cybergear.watchdog import StopWatchdog
from tests.can_util import virtual_rig
from tests.spine_module.buses.cybergear.test_safety_motors import (
    test_bad_motor_config_names_file_and_field as refused_naming_file_and_field,
)

BASE = DEFAULT_CONFIG_PATH.read_text()


def _with(bus: str = "", joint: str = "") -> str:
    """The packaged file with `bus` = "key = value" lines set in [bus], `joint` lines in the first [[joint]]
    (a key the file already has is replaced)."""
    text = BASE
    for line, table in [(x, "[bus]\n") for x in bus.splitlines()] + [(x, 'name = "q2"\n')
                                                                  for x in joint.splitlines()]:
        key = line.split("=")[0].strip()
        text = re.sub(rf"(?m)^{key} = .*$", "#", text, count=1 if table == "[bus]\n" else 0)
        text = text.replace(table, f"{table}{line}\n", 1)
    return text


# hostile values by class: each must be refused naming the field (the message fragment)
HOSTILE = [
    # a CAN timeout that the firmware would read as off
    (_with(bus="can_timeout_s = 0.00001"), "rounds to 0 CAN_TIMEOUT ticks"),
    (_with(bus="can_timeout_s = 2e-5"), "rounds to 0 CAN_TIMEOUT ticks"),
    (_with(bus="can_timeout_s = 0.0"), "also set can_timeout_off = true"),
    (_with(bus="can_timeout_off = true"), "can_timeout_off = true needs can_timeout_s = 0"),
    (_with(bus='can_timeout_off = "yes"'), "can_timeout_off must be true or false"),
    (_with(bus="can_timeout_s = 0.001"), "two control periods"),
    # values that divide by ~0, reach the motors, or switch a detection off
    (_with(joint="gear_ratio = 1e-300"), "gear_ratio must be in [0.1, 100]"),
    (_with(joint="gear_ratio = 7.75"), "outside the frames' +-12.5 rad"),  # the internal gearbox twice
    (_with(joint="torque_scale = 1e6"), "torque_scale must be in"),
    (_with(joint="zero_offset_rad = 1e12"), "zero_offset_rad must be in"),
    (_with(joint="zero_offset_rad = 12.4"), "outside the frames' +-12.5 rad"),
    (_with(bus="limit_torque_nm = 1e12"), "limit_torque_nm must be in [0.01, 12]"),
    (_with(bus="silent_timeout_s = 1e9"), "silent_timeout_s must be in"),
    (_with(bus="silent_timeout_s = 1e-6"), "silent_timeout_s must be in"),
    (_with(bus="position_max_rad = 1e-9"), "position_max_rad must be in"),
    (_with(bus="position_max_rad = 1e9"), "position_max_rad must be in"),
    (_with(bus="kt_nm_per_a = 1e6"), "kt_nm_per_a must be in"),
    (_with(bus="rate_hz = 1e12"), "rate_hz must be in"),
    (_with(bus="bitrate = 1000000000"), "bitrate must be in"),
    (_with(bus="handshake_timeout_s = 1e9"), "handshake_timeout_s"),
]


@pytest.mark.parametrize("text,needle", HOSTILE, ids=[n for _, n in HOSTILE])
def test_hostile_motor_config_is_refused_naming_the_field(tmp_path, text, needle):
    refused_naming_file_and_field(tmp_path, text, needle)


def test_sane_values_still_load(tmp_path):
    path = tmp_path / "motors.toml"
    path.write_text(_with(bus='position_max_rad = "4pi"\nlimit_torque_nm = 4.0', joint="gear_ratio = 2.0"))
    cfg = load_config(path)
    assert cfg.position_max_rad == pytest.approx(4 * math.pi) and cfg.joints[0].gear_ratio == 2.0
    assert load_config().can_timeout_ticks == 1000  # the shipped 0.05 s


def test_can_timeout_off_only_when_stated_and_loudly(tmp_path, caplog):
    path = tmp_path / "motors.toml"
    path.write_text(BASE.replace("can_timeout_s = 0.05", "can_timeout_s = 0\ncan_timeout_off = true"))
    cfg = load_config(path).with_(silent_timeout_s=0.5)
    assert cfg.can_timeout_off
    with virtual_rig() as (channel, emu, _sn), caplog.at_level(logging.WARNING):
        with CanMotorBus(cfg, interface="virtual", channel=channel) as mb:
            mb.start()
            assert mb.can_timeout_confirmed == {}
        assert all(m.params["CAN_TIMEOUT"] == 0 for m in emu.motors.values())
    assert "MOTOR WATCHDOG OFF" in caplog.text


@pytest.mark.parametrize("deadline", [1e12, 0.0, 1e-6, 6.0])
def test_watchdog_deadline_is_bounded(deadline):
    bus = can.Bus(interface="virtual", channel="wd-range")
    try:
        with pytest.raises(ValueError, match="watchdog deadline must be in"):
            StopWatchdog(bus, [1, 2, 3], deadline_s=deadline)
    finally:
        bus.shutdown()


def test_cli_watchdog_refuses_a_deadline_that_never_fires(capsys):
    from sparc_quad.cli import main

    with pytest.raises(SystemExit) as exc:  # refused while parsing, by the watchdog's own bounds
        main(["motors", "watchdog", "--can-interface", "virtual", "--can-channel", "wd-cli",
              "--deadline", "1e12"])
    err = capsys.readouterr().err
    assert exc.value.code == 2 and "argument --deadline: must be in [0.002, 5.0]" in err
    assert "Traceback" not in err


@pytest.mark.parametrize("key,raw", [
    ("limit_torque", struct.pack("<f", math.nan)),
    ("limit_torque", struct.pack("<f", math.inf)),
    ("VBUS", struct.pack("<f", -math.inf)),
    ("limit_torque", struct.pack("<f", 1e12)),
    ("CAN_TIMEOUT", struct.pack("<I", 0xFFFFFFFF)),
])
def test_parameter_read_reply_with_nan_inf_or_out_of_range_is_invalid(key, raw):
    good = P.encode_param_read_reply(1, P.DEFAULT_HOST_ID, key, 1)
    assert P.decode_from_motor(good, P.DEFAULT_HOST_ID).value == pytest.approx(1)
    bad = can.Message(arbitration_id=good.arbitration_id, data=bytes(good.data[:4]) + raw,
                      is_extended_id=True)
    with pytest.raises(P.FrameError, match=f"read reply for {key}"):
        P.decode_from_motor(bad, P.DEFAULT_HOST_ID)


# --- the CyberGear's ranges live in spine_module.params.CYBERGEAR only ------------------------------------
ROOT = Path(__file__).resolve().parents[4]
COPIES = ("spine_module/buses/cybergear/protocol.py", "spine_module/buses/cybergear/config.py",
          "spine_module/messages/codec.py")
HARDWARE_NUMBERS = {12.5, 500.0, 23.0, 20000, 100000}  # 500 m/s^2 is also the codec's ddx_d bound


def _numbers(path: Path) -> set[float]:
    toks = tokenize.generate_tokens(io.StringIO(path.read_text()).readline)
    return {float(ast.literal_eval(t.string)) for t in toks if t.type == tokenize.NUMBER}


def test_cybergear_ranges_are_not_copied():
    for rel in COPIES:
        assert not _numbers(ROOT / rel) & (HARDWARE_NUMBERS - ({500.0} if "codec" in rel else set())), rel
    from spine_module.messages import codec
    assert codec.MOTOR_COMMAND_RANGES["kp"].hi == params.CYBERGEAR.kp_nm_rad
    assert codec.MOTOR_COMMAND_RANGES["kd"].hi == params.CYBERGEAR.kd_nm_s_rad
    bus = tomllib.loads(DEFAULT_CONFIG_PATH.read_text())["bus"]
    assert "position_max_rad" not in bus and "limit_torque_nm" not in bus  # defaults from params
    cg, r = params.CYBERGEAR, P.DEFAULT_RANGES
    assert (r.position_max, r.velocity_max, r.torque_max, r.kp_max, r.kd_max) == (
        cg.position_rad, cg.velocity_rad_s, cg.torque_nm, cg.kp_nm_rad, cg.kd_nm_s_rad)
    assert params.SENSORS.position_lsb_rad == pytest.approx(2 * cg.position_table_rad / 0xFFFF)
    assert params.SENSORS.torque_lsb_nm == pytest.approx(2 * r.torque_max / 0xFFFF)
    assert load_config().position_max_rad == cg.position_rad and load_config().limit_torque_nm == cg.torque_nm
