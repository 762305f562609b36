"""Node clocks, the backend registry and the two commands' in-process paths."""

from __future__ import annotations

import argparse
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
    assert isinstance(registry.make_bus("inprocess", argparse.Namespace()), InProcessBus)
    with pytest.raises(ValueError, match="unknown motor backend 'nope'"):
        registry.make_bus("nope", argparse.Namespace())
    registry.register("broken", "spine_module.buses.does_not_exist")
    try:
        with pytest.raises(ValueError, match="not available"):
            registry.make_bus("broken", argparse.Namespace())
    finally:
        del registry.BACKENDS["broken"]


def test_spine_node_inprocess_static(capsys):
    rc = main(["spine-node", "--motors", "inprocess", "--experiment", "static", "--k", "400",
               "--period", "0.5", "--duration", "0.5", "--soft-start", "0"])
    out = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert rc == 0 and out["ticks"] == 500 and 100 < out["k_hat_n_m"] < 800


def test_help_lists_both_commands(capsys):
    with pytest.raises(SystemExit):
        main(["--help"])
    text = capsys.readouterr().out
    assert "spine-node" in text and "bench-robot" in text
