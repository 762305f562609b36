"""Issue 10: bad input at every boundary ends in a clear error naming what was wrong, never a traceback.

SPARC_SPINE_STATE with out-of-range enums (codec + spine-echo), `motors` actions without a terminal.
"""

from __future__ import annotations

import io
import json
from types import SimpleNamespace

import pytest

from spine_module.messages import MessageError, SpineState, channels, codec
from spine_module.messages.lcmt.sparc import spine_state_t


def _state_bytes(**fields) -> bytes:
    m = spine_state_t.decode(codec.encode_state(SpineState(seq=3)))
    for k, v in fields.items():
        setattr(m, k, v)
    return m.encode()


@pytest.mark.parametrize("field,value", [("mode", 99), ("mode", -1), ("requested_mode", 7),
                                         ("faults", 1 << 30), ("faults", -5)])
def test_spine_state_out_of_range_enum_is_a_message_error_naming_the_field(field, value):
    with pytest.raises(MessageError) as e:
        codec.decode_state(_state_bytes(**{field: value}))
    assert f"SPARC_SPINE_STATE.{field}" in str(e.value)


class _FakeLcm:
    """Delivers a fixed list of packets to the one subscriber, then nothing."""

    def __init__(self, packets):
        self.packets = list(packets)
        self.cb = None

    def subscribe(self, regex, cb):
        self.cb = cb

    def handle_timeout(self, ms):
        if self.packets:
            self.cb(*self.packets.pop(0))
            return 1
        return 0


def test_spine_echo_survives_bad_packets(monkeypatch, capsys):
    """One out-of-range state packet between two good ones: three lines, the middle one rejected."""
    import lcm

    from sparc_quad.cli.node import run_spine_echo

    good = codec.encode_state(SpineState(seq=1))
    packets = [(channels.SPINE_STATE, good), (channels.SPINE_STATE, _state_bytes(mode=42)),
               (channels.SPINE_STATE, b"\x00" * 3), (channels.SPINE_STATE, good)]
    monkeypatch.setattr(lcm, "LCM", lambda url: _FakeLcm(packets))
    rc = run_spine_echo(SimpleNamespace(lcm_url="memq://", channels="SPARC_.*", count=4, timeout=5.0))
    lines = [json.loads(x) for x in capsys.readouterr().out.strip().splitlines()]
    assert rc == 0 and len(lines) == 4
    assert "SPARC_SPINE_STATE.mode" in lines[1]["rejected"]
    assert "rejected" in lines[2] and lines[3]["seq"] == 1


@pytest.mark.parametrize("action", ["enable", "zero", "set-id"])
def test_motors_actions_without_terminal_need_yes(action, monkeypatch, capsys):
    """`echo n | sparc-quad motors enable` used to enable every motor: without a terminal it now refuses
    (exit 2) before opening the bus, unless --yes is given."""
    import sparc_quad.cli.motors as motors_cli
    from sparc_quad.cli import main
    from spine_module.buses.cybergear import driver

    opened = []

    def no_bus(*a, **k):
        opened.append(a)
        raise AssertionError("bus opened")
    monkeypatch.setattr(driver, "open_bus", no_bus)
    monkeypatch.setattr(motors_cli, "open_bus", no_bus, raising=False)
    monkeypatch.setattr("sys.stdin", io.StringIO("n\n"))
    extra = ["--new-id", "5", "--ids", "1"] if action == "set-id" else []
    rc = main(["motors", action, "--can-interface", "virtual", "--can-channel", "no-tty", *extra])
    assert rc == 2 and not opened
    assert "--yes" in capsys.readouterr().err
