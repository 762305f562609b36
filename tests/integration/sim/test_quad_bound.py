"""The spined quadruped bounding in process: no fall, forward progress, determinism, estimator."""

from __future__ import annotations

import numpy as np
import pytest

from sparc_quad.bound.run import BoundConfig, run_bound, write_outputs
from sparc_quad.sim.quadruped_world import Estimator, ImuConfig
from sparc_quad.sim.spine_drive import SpineGains
from tests.paths import ROOT


@pytest.fixture(scope="module")
def bound3():
    return run_bound(BoundConfig(duration_s=3.0, settle_s=0.5))


def test_bounds_without_falling_and_moves_forward(bound3):
    m = bound3.metrics
    assert not m["fell"], m["fall_reason"]
    assert m["distance_m"] > 0.3
    # touchdowns counted from foot contact, not the gait clock: one hind-left touchdown per 4 Hz stride
    assert m["touchdown_frequency_hz"] == pytest.approx(4.0, rel=0.05)
    assert m["hind_touchdowns_per_stride"] == pytest.approx(1.0)
    assert 0.2 < m["duty_HL"] < 0.8


def test_spine_controller_used_the_estimator_q1(bound3):
    q1_true, q1_est = bound3.column("q1_true"), bound3.column("q1_est")
    assert not np.array_equal(q1_true, q1_est)  # noise + delay: what the controller saw is the estimate
    assert np.abs(q1_true - q1_est).max() < 0.05


def test_same_config_same_trajectory():
    cfg = BoundConfig(duration_s=1.0)
    a, b = run_bound(cfg), run_bound(cfg)
    np.testing.assert_array_equal(a.series, b.series)


def test_rigid_spine_baseline_bounds_and_stays_rigid():
    r = run_bound(BoundConfig(duration_s=2.0, spine_variant="rigid", settle_s=0.2))
    assert not r.metrics["fell"]
    assert r.metrics["spine_x_range_m"] < 0.005


def test_soft_spine_corner_bounds():
    soft = SpineGains(k=(300.0, 1000.0, 15.0), d=(2.0, 20.0, 0.3))
    cfg = BoundConfig(duration_s=2.0, spine=soft, settle_s=0.2)
    assert not run_bound(cfg).metrics["fell"]


def test_estimator_is_seeded_and_delayed():
    def trace(seed, delay):
        est = Estimator(ImuConfig(delay_steps=delay), 1e-3, np.random.default_rng(seed))
        return [est.update(0.001 * k, 0.0).q1 for k in range(20)]

    assert trace(1, 2) == trace(1, 2)
    assert trace(1, 2) != trace(2, 2)
    clean = Estimator(ImuConfig(0, 0, 0, 0, 0, delay_steps=3), 1e-3, np.random.default_rng(0))
    out = [clean.update(0.001 * k, 0.0).q1 for k in range(10)]
    assert out[5] == pytest.approx(0.002)  # three steps late


def test_outputs_written(bound3, tmp_path):
    paths = write_outputs(bound3, tmp_path)
    names = {p.name for p in paths}
    assert {"metrics.json", "timeseries.csv", "gait_diagram.png", "body_pitch.png", "spine_task_space.png",
            "torques.png"} <= names


@pytest.mark.slow
def test_twenty_second_stability_grid():
    import importlib.util

    script = ROOT / "bench" / "bound_grid.py"
    spec = importlib.util.spec_from_file_location("bound_grid", script)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    rows = mod.grid(20.0)
    assert not [r for r in rows if r["fell"]]


def test_cli_bound_writes_outputs(tmp_path, capsys):
    from sparc_quad.cli import main

    argv = ["bound", "--duration", "1.5", "--kx", "800", "--dx", "10", "--speed", "0.4"]
    argv += ["--out", str(tmp_path)]
    rc = main(argv)
    assert rc == 0
    import json

    def refuse(token):  # strict JSON: an undefined metric is null, never a NaN token
        raise AssertionError(f"metrics.json holds {token}")

    m = json.loads((tmp_path / "metrics.json").read_text(), parse_constant=refuse)
    assert None in m.values()  # 1.5 s is too short for the steady-window metrics: they are null
    assert m["config"]["spine"]["k"][0] == 800.0 and m["config"]["gait"]["speed_m_s"] == 0.4
    assert (tmp_path / "timeseries.csv").read_text().startswith("t [s],x [m],y [m],z [m]")


def test_cli_lcm_without_a_node_says_what_to_start(tmp_path, capsys):
    from sparc_quad.cli import main

    # LCM's default URL needs a multicast route; memq:// is in-process and has no node on it
    argv = ["bound", "--lcm", "--lcm-url", "memq://", "--wait-node", "0.2", "--out", str(tmp_path)]
    assert main(argv) == 2
    assert "spine-node --motors lcm" in capsys.readouterr().err
    assert main(["bound", "--lcm", "--spine", "rigid", "--out", str(tmp_path)]) == 2


def test_node_in_process_bounds_and_runs_on_the_estimate():
    from sparc_quad.robot_side.quad import NodeSpine

    cfg = BoundConfig(duration_s=1.5, settle_s=0.2)
    r = run_bound(cfg, spine=NodeSpine.inprocess(cfg.spine))
    assert not r.metrics["fell"] and r.metrics["spine_driver"] == "node"
    np.testing.assert_array_equal(r.node_states["node_q"][:, 0], r.column("q1_est"))
    assert not r.node_states["node_faults"].any()


def test_cli_bound_no_plots_never_imports_matplotlib(tmp_path):
    import subprocess
    import sys

    code = ("import sys; from sparc_quad.cli import main; rc = main(sys.argv[1:]); "
            "print('MPL', 'matplotlib' in sys.modules); sys.exit(rc)")
    argv = ["bound", "--duration", "0.05", "--no-plots", "--out", str(tmp_path / "o")]
    r = subprocess.run([sys.executable, "-c", code, *argv], capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    assert "MPL False" in r.stdout
    written = sorted(p.name for p in (tmp_path / "o").iterdir())
    assert written == ["metrics.json", "scenario.json", "timeseries.csv"]
    r = subprocess.run([sys.executable, "-m", "sparc_quad", *argv, "--video"], capture_output=True, text=True,
                       timeout=300)
    assert r.returncode == 2 and "--no-plots" in r.stderr and "Traceback" not in r.stderr
