"""Bad input at every boundary ends in a clear error naming what was wrong, never a traceback.

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

    from sparc_quad.cli.spine_echo import run as run_spine_echo

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


_FRICTION = {"tau_c_nm": 0.05, "tau_s_nm": 0.08, "b_nm_s_rad": 0.01, "dq_s_rad_s": 0.05, "alpha": 2.0,
             "beta_s_rad": 50.0}


@pytest.mark.parametrize("doc,needle", [
    ('{"armature_kg_m2": -1e-4}', "armature_kg_m2 must be >= 0, got -0.0001"),
    ('{"armature_kg_m2": NaN}', "armature_kg_m2 must be finite"),
    ('{"armature_kg_m2": "big"}', "armature_kg_m2 must be a number"),
    (json.dumps({"friction": {**_FRICTION, "tau_c_nm": -0.1}}), "friction.tau_c_nm must be >= 0"),
    (json.dumps({"friction": {**_FRICTION, "beta_s_rad": 0}}), "friction.beta_s_rad must be > 0"),
    (json.dumps({"friction": {k: v for k, v in _FRICTION.items() if k != "alpha"}}),
     "friction: missing alpha"),
    (json.dumps({"friction": {**_FRICTION, "coulomb": 1}}), "friction: unknown key 'coulomb'"),
    ('{"sensors": {"torque_noise_nm": Infinity}}', "sensors.torque_noise_nm must be finite"),
    ('{"quantise": "yes"}', "quantise must be true or false"),
    ('{"armature": 0.001}', "unknown plant keys ['armature']"),
    ('{"effects": [1, 2]}', "effects must be an object or null"),
    ("[1, 2, 3]", "the top level must be a JSON object, got list"),
    ("{not json", "not a usable plant file"),
])
def test_bench_plant_file_errors_name_file_and_field_exit_2(tmp_path, doc, needle, capsys):
    from sparc_quad.cli import main

    path = tmp_path / "plant.json"
    path.write_text(doc)
    with pytest.raises(SystemExit) as e:
        main(["bench", "static", "--quick", "--plant", str(path), "--out", str(tmp_path / "out")])
    err = capsys.readouterr().err
    assert e.value.code == 2 and str(path) in err and needle in err, err
    assert "Traceback" not in err and not (tmp_path / "out").exists()


def test_bench_plant_file_missing_and_good(tmp_path, capsys):
    from sparc_quad.cli import main
    from sparc_quad.sim.plant import PlantConfig

    with pytest.raises(SystemExit) as e:
        main(["bench", "static", "--plant", str(tmp_path / "nosuch.json"), "--out", str(tmp_path / "o")])
    assert e.value.code == 2 and "cannot read the plant file" in capsys.readouterr().err
    good = PlantConfig()
    path = tmp_path / "plant.json"
    path.write_text(json.dumps(good.to_json()))
    assert PlantConfig.load(path) == good  # a file the project writes reads back unchanged
