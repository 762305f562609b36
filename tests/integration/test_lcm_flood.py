"""A garbage flood on each of the node's LCM inputs in turn, across processes on UDP multicast (network
namespace), real time: bench/lcm_flood.py with the flood at 10 000 msg/s (this shared 2-core machine cannot
run node, robot and a 75 000 msg/s flooder at once: then the decoy run alone drops the node to ~500 Hz).
Counts only: no latch, no more HEARTBEAT_LOST / TORSO_STALE ticks than the same run with the flood on a
channel nobody reads (plus a margin for a loaded host), and the flooded channel's garbage refused."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from tests.node_netns import unshare_prefix
from tests.paths import ROOT

pytestmark = [pytest.mark.slow, pytest.mark.netns,
              pytest.mark.skipif(unshare_prefix() is None, reason="cannot create a network namespace here")]


ATTEMPTS = 3  # a run whose decoy alone was starved by the host is measured again, then it fails


def _measure(tmp_path) -> dict:
    out = tmp_path / "flood.json"
    r = subprocess.run([sys.executable, str(ROOT / "bench" / "lcm_flood.py"), "--seconds", "3", "--rate",
                        "10000", "--json", str(out)], cwd=ROOT, capture_output=True, text=True, timeout=900)
    assert r.returncode == 0, r.stderr[-3000:]
    return json.loads(out.read_text())


def test_garbage_flood_on_each_input_latches_nothing(tmp_path):
    for _ in range(ATTEMPTS):
        res = _measure(tmp_path)
        base = res["decoy"]
        assert not base["latched"] and base["flood_sent"] > 0
        if base["ticks_heartbeat_lost"] <= 0.2 * base["robot_ticks"]:
            break
    else:  # the host, not the flood, starved the decoy run every time: no comparison can be made
        pytest.fail(f"host too loaded for this real-time comparison in {ATTEMPTS} attempts: the decoy run "
                    f"alone lost the heartbeat in {base['ticks_heartbeat_lost']} of {base['robot_ticks']} "
                    f"ticks, load {res['loadavg']}; run it on an idle machine (make test-slow)")
    for c in res["flooded"]:
        assert not c["latched"], c
        assert c["refused"] > 0.1 * c["flood_sent"], c  # the flood reached the node and was refused
        assert c["ticks_heartbeat_lost"] <= base["ticks_heartbeat_lost"] + 50, (c, base)
        assert c["ticks_torso_stale"] <= base["ticks_torso_stale"] + 100, (c, base)
    print(json.dumps({c["channel"]: {k: c[k] for k in ("rate_ratio", "refused", "flood_sent",
                                                       "ticks_heartbeat_lost", "ticks_torso_stale")}
                      for c in res["flooded"]}))
