"""The quadruped over LCM: the quadruped sim (`sparc-quad bound --lcm`) and the spine node
(`sparc-quad spine-node --motors lcm`) as separate processes on UDP multicast inside a network namespace this
test creates, in lockstep, against the same bound with the node in process.

Asserts: no fall and forward progress both ways; every tick answered; the node's q1 is the estimator's q1
(noise, bias and delay included) on every tick; the LCM trajectory equals the in-process one.
Run on LCM's default provider (udpm, the URL every LCM tool uses) and on the co-simulation's
(`channels.COSIM_URL`, mpudpm); the first run also receives the node's spine states (`--lcm-node-states`),
the second does not (the default) and writes no node_states.npz. Reduced size (2.5 s of bounding) to keep
the default suite short.
"""

from __future__ import annotations

import json
import shlex
import sys
from pathlib import Path

import numpy as np
import pytest

from sparc_quad.bound.run import BoundConfig, run_bound
from sparc_quad.robot_side.quad import NodeSpine
from spine_module.messages import channels
from tests.node_netns import run_in_netns, unshare_prefix
from tests.paths import ROOT

DURATION = 2.5

pytestmark = [pytest.mark.netns,
              pytest.mark.skipif(unshare_prefix() is None, reason="cannot create a network namespace here")]


@pytest.fixture(scope="module", params=["default", "cosim"])
def lcm_run(request, tmp_path_factory):
    # bound replaces its --out folder when done (atomic output): the node's files live beside it
    out = tmp_path_factory.mktemp("quad_lcm")
    py = shlex.quote(sys.executable)
    url = f"--lcm-url {shlex.quote(channels.COSIM_URL)} " if request.param == "cosim" else ""
    states = request.param == "default"  # the robot also receives the node's spine states
    states_opt = "--lcm-node-states " if states else ""
    script = f"""
export PYTHONPATH={shlex.quote(str(ROOT))}
{py} -m sparc_quad spine-node --motors lcm --clock lockstep --idle-timeout 3 {url}\
    --summary {out}/node.json > {out}/node.out 2> {out}/node.err &
NODE=$!
{py} -m sparc_quad bound --lcm {url}{states_opt}--duration {DURATION} --out {out}/bound \
    > {out}/robot.out 2> {out}/robot.err
wait $NODE
"""
    r = run_in_netns(script, ROOT, timeout_s=240)
    logs = "\n".join(f"--- {p.name}\n{p.read_text()[-3000:]}" for p in sorted(out.glob("*.err")))
    assert r.returncode == 0, f"rc={r.returncode}\n{r.stderr}\n{logs}"
    return out, logs, states


@pytest.fixture(scope="module")
def inprocess_run():
    cfg = BoundConfig(duration_s=DURATION, stop_on_fall=False)
    return run_bound(cfg, spine=NodeSpine.inprocess(cfg.spine))


def _series(path: Path) -> tuple[list[str], np.ndarray]:
    from sparc_quad.sim.bound_log import column_name

    header = [column_name(f) for f in path.read_text().split("\n", 1)[0].split(",")]
    return header, np.loadtxt(path, delimiter=",", skiprows=1)


def test_both_bound_without_falling_and_move_forward(lcm_run, inprocess_run):
    out, logs, _ = lcm_run
    m = json.loads((out / "bound" / "metrics.json").read_text())
    assert not m["fell"], logs
    assert m["distance_m"] > 0.2
    assert not inprocess_run.metrics["fell"] and inprocess_run.metrics["distance_m"] > 0.2


def test_every_tick_answered_and_node_used_the_estimators_q1(lcm_run):
    out, logs, states_asked = lcm_run
    node = json.loads((out / "node.json").read_text())
    ticks = round(DURATION * 1000)
    assert node["ticks"] == ticks and node["rejected"] == 0, logs
    assert node["lockstep_torso_missing"] == 0  # each tick ran on its own torso state (mpudpm may reorder)
    assert not node["lockstep_opening_incomplete"]  # and the first on the robot's opening command
    if not states_asked:
        assert not (out / "bound" / "node_states.npz").exists()  # not asked for: not received
        return
    states = np.load(out / "bound" / "node_states.npz")
    header, s = _series(out / "bound" / "timeseries.csv")
    q1_est, q1_true = s[:, header.index("q1_est")], s[:, header.index("q1_true")]
    assert len(states["node_q"]) == ticks
    # what the node ran on, tick by tick, is exactly what the robot published from its estimator
    np.testing.assert_array_equal(states["node_q"][:, 0], states["robot_sent_q1"])
    np.testing.assert_allclose(states["robot_sent_q1"], q1_est, rtol=0, atol=1e-8)
    assert not np.array_equal(q1_est, q1_true)  # and that was the estimate, not the truth
    np.testing.assert_array_equal(states["node_feedback_seq"], np.arange(ticks))


def test_lockstep_over_lcm_equals_inprocess(lcm_run, inprocess_run):
    out, _, _ = lcm_run
    header, s = _series(out / "bound" / "timeseries.csv")
    ref = inprocess_run.series
    assert s.shape == ref.shape
    for name in ("x", "z", "q1_true", "q2", "q3", "q4", "tau2", "tau3", "tau4"):
        k = header.index(name)
        assert np.max(np.abs(s[:, k] - ref[:, k])) <= 1e-7, name  # CSV keeps 9 significant digits
