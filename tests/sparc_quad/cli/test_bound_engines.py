"""`sparc-quad bound --host spined-dog --engine pybullet|mujoco --gait sine` writes the usual outputs."""

from __future__ import annotations

import json

import pytest

from sparc_quad.cli import main

pytest.importorskip("mujoco")


@pytest.mark.parametrize("engine", ["mujoco", "pybullet"])
def test_bound_on_the_spined_dog_in_either_engine(tmp_path, engine, capsys):
    out = tmp_path / engine
    rc = main(["bound", "--host", "spined-dog", "--engine", engine, "--gait", "sine", "--step-length", "0.08",
               "--kx", "800", "--duration", "0.5", "--no-plots", "--out", str(out)])
    m = json.loads((out / "metrics.json").read_text())
    assert rc == (1 if m["fell"] else 0)
    assert (out / "timeseries.csv").read_text().count("\n") == 501  # header + one row per 1 ms step
    assert m["config"]["world"]["engine"] == engine and m["config"]["world"]["host"] == "spined-dog"
    assert '"fell"' in capsys.readouterr().out


def test_unknown_engine_is_refused(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["bound", "--engine", "ode", "--duration", "0.1"])
    assert exc.value.code == 2 and "ode" in capsys.readouterr().err
