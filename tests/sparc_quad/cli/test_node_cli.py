"""Node clocks, the backend registry and the two commands' in-process paths."""

from __future__ import annotations

import itertools
import json

import numpy as np
import pytest

from sparc_quad.cli import main
from spine_module.buses import registry
from spine_module.buses.inprocess import InProcessBus
from spine_module.node.clocks import PeriodStats, RealTimeClock


def test_period_stats_window_max():
    rng = np.random.default_rng(1)
    walls = np.concatenate(([0.0], np.cumsum(0.001 + rng.uniform(0, 0.002, 400))))
    ps = PeriodStats(0.001, window=50)
    devs = []
    for i, w in enumerate(walls):
        ps.mark(float(w))
        if i:
            devs.append(abs(walls[i] - walls[i - 1] - 0.001))
            assert ps.jitter_max == pytest.approx(max(devs[-50:]), abs=1e-15)
            assert ps.period == pytest.approx(walls[i] - walls[i - 1])


def test_realtime_clock_advances():
    clock = RealTimeClock(2000.0)
    ts = [clock.wait() for _ in range(5)]
    assert all(b > a for a, b in itertools.pairwise(ts))


def test_registry_names_backends_and_errors_clearly():
    assert {"lcm", "inprocess", "can"} <= set(registry.BACKENDS)
    assert isinstance(registry.make_bus("inprocess"), InProcessBus)
    with pytest.raises(ValueError, match="unknown motor backend 'nope'"):
        registry.make_bus("nope")
    with pytest.raises(ValueError, match=r"takes no option.*chanel"):  # a misspelt option is named
        registry.make_bus("can", chanel="can0")
    registry.register("broken", "spine_module.buses.does_not_exist")
    try:
        with pytest.raises(ValueError, match="not available"):
            registry.make_bus("broken")
    finally:
        del registry.BACKENDS["broken"]


def test_can_bus_from_keywords_like_python_can():
    """The CAN backend is built from keyword arguments, as can.Bus(interface=..., channel=...) is."""
    bus = registry.make_bus("can", interface="virtual", channel="kw-test", bitrate=500_000)
    try:
        assert bus.joint_names == ("q2", "q3", "q4") and bus.bus.channel_info
    finally:
        bus.shutdown()


def test_spine_node_inprocess_static(capsys):
    rc = main(["spine-node", "--motors", "inprocess", "--experiment", "static", "--kx", "400",
               "--period", "0.5", "--duration", "0.5", "--soft-start", "0"])
    out = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert rc == 0 and out["ticks"] == 500 and 100 < out["k_hat_n_m"] < 800


def test_help_lists_both_commands(capsys):
    with pytest.raises(SystemExit):
        main(["--help"])
    text = capsys.readouterr().out
    assert "spine-node" in text and "bench-robot" in text


def test_spine_cmd_validates_before_sending(capsys):
    with pytest.raises(SystemExit):  # a gain beyond the node's limit: refused while parsing
        main(["spine-cmd", "--lcm-url", "memq://", "--kx", "1e9"])
    assert "argument --kx" in capsys.readouterr().err
    assert main(["spine-cmd", "--lcm-url", "memq://", "--x-d", "5", "0", "0"]) == 2  # the codec's range
    assert "SPARC_SPINE_COMMAND.x_d[0]" in capsys.readouterr().err
    assert main(["spine-cmd", "--lcm-url", "memq://", "--mode", "estop"]) == 0
    assert json.loads(capsys.readouterr().out.strip().splitlines()[-1]) == {"sent": 1, "mode": "ESTOP"}


def test_spine_echo_lines_decoded_and_rejected():
    from sparc_quad.cli.spine_echo import echo_line
    from spine_module.buses.base import MotorCommand
    from spine_module.messages import SpineCommand, TorsoState, channels, codec

    line = echo_line(channels.SPINE_COMMAND, codec.encode_command(SpineCommand(seq=4)))
    assert line["channel"] == channels.SPINE_COMMAND and line["seq"] == 4 and line["mode"] == "IMPEDANCE"
    assert line["k"] == [500.0, 1000.0, 15.0]
    json.dumps(line)
    line = echo_line(channels.MOTOR_COMMAND, codec.encode_motor_command(MotorCommand.zero(), feedback_seq=7))
    assert line["feedback_seq"] == 7 and line["enable"] is False
    bad = echo_line(channels.SPINE_COMMAND, codec.encode_torso(TorsoState()))
    assert "wrong fingerprint" in bad["rejected"]


def test_spine_node_with_silent_motors_exits_cleanly_naming_them(caplog):
    """No motor answers the start-up handshake: an error naming each motor, exit code 1, no traceback."""
    from sparc_quad.cli import main

    with caplog.at_level("ERROR"):
        rc = main(["spine-node", "--motors", "can", "--can-interface", "virtual", "--can-channel",
                   "silent-start", "--lcm-url", "memq://", "--duration", "0.2"])
    assert rc == 1
    text = caplog.text
    assert "start-up failed" in text and "q2" in text and "q4" in text
