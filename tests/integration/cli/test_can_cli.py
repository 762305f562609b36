"""`sparc-quad motors ...` against emulated motors on a virtual channel, and bench/can_loop.py."""

from __future__ import annotations

import json
import runpy
import sys

import can

from sparc_quad.cli import main
from tests.can_util import virtual_rig
from tests.paths import ROOT


def _motors(channel, *args):
    # the timeout bounds the wait for answers that come (the emulator answers at once, but on a loaded
    # machine its thread may wait for the CPU); only `status --ids 1,4` waits it out, for motor 4
    return main(["motors", *args, "--can-interface", "virtual", "--can-channel", channel, "--timeout", "2"])


def test_motors_cli(capsys, tmp_path):
    with virtual_rig(lockstep=False) as (channel, emu, _sn):
        assert _motors(channel, "scan") == 0
        out = capsys.readouterr().out
        assert all(f"     {i}  c6b0" in out for i in (1, 2, 3))
        assert _motors(channel, "status") == 0 and capsys.readouterr().out.count("VBUS=24") == 3
        assert _motors(channel, "enable", "--yes") == 0 and capsys.readouterr().out.count("mode RUN") == 3
        emu.load.q[2] = 0.75
        assert _motors(channel, "zero", "--yes", "--ids", "2") == 0
        assert emu.motors[2].zero_rad == 0.75
        pos = float(capsys.readouterr().out.split("position ")[1].split(" rad")[0])
        assert abs(pos) < 1e-3  # the new zero, within one position LSB
        assert _motors(channel, "disable", "--clear-fault") == 0
        assert capsys.readouterr().out.count("mode RESET") == 3
        log = tmp_path / "set-id.asc"
        assert _motors(channel, "set-id", "--ids", "3", "--new-id", "5", "--yes", "--can-log", str(log)) == 0
        assert "motor 3 -> 5: answered" in capsys.readouterr().out
        assert sorted(emu.motors) == [1, 2, 5]
        frames = list(can.LogReader(str(log)))
        assert [f.arbitration_id >> 24 for f in frames] == [7, 0]  # the request and the motor's answer
        assert _motors(channel, "status", "--ids", "1,4") == 1
        assert "motor 4: no answer" in capsys.readouterr().out


def test_can_loop_bench(tmp_path, monkeypatch):
    out = tmp_path / "can_loop.json"
    monkeypatch.setattr(sys, "argv", ["can_loop.py", "--seconds", "0.3", "--json", str(out)])
    try:
        runpy.run_path(str(ROOT / "bench" / "can_loop.py"), run_name="__main__")
    except SystemExit as e:
        assert e.code == 0
    doc = json.loads(out.read_text())
    assert doc["max"]["cycles"] > 0 and doc["paced"]["cycles"] > 0
    assert doc["max"]["tx_frames_per_s"] > 0 and doc["max"]["rx_frames_per_s"] > 0
    assert doc["bus_load_model"]["utilisation_worst"] == 0.96
    pc = doc["paced"]
    assert pc["cpu_per_cycle_us"] > 0
    hc = pc["host_ceiling"]  # the same clock without a bus, doing the loop's CPU per cycle as Python work
    assert hc["cycles"] > 0 and hc["work_cpu_per_cycle_us"] >= 0
    # the calibrated work runs at least as long as calibrated (load only makes CPU time longer)
    assert hc["cpu_per_cycle_us"] >= 0.8 * hc["work_cpu_per_cycle_us"]
