"""The spine node under a garbage flood on one of its LCM input channels, against the same run with the
same flood on a channel nobody subscribes (the decoy: the same CPU and network load, nothing for the
node to look at), in the same namespace, one after the other.

Separate processes on UDP multicast inside a private network namespace (`unshare`, as the tests do):
`spine-node --clock realtime` + `bench-robot --clock realtime --experiment hold` (torso state and motor
feedback every 1 ms, heartbeat and command every 10 ms) + a flooder publishing random payloads (0-120
bytes) at `--rate` messages/s, paced by count (each millisecond it catches up to rate x elapsed).

Per case: the node's achieved tick rate, the robot's `latched`, the ticks whose spine state carried
HEARTBEAT_LOST / TORSO_STALE, the node's refused count on the flooded channel, the flooder's sent count.
Headline: `rate_ratio` = the node's tick rate under the flood / under the decoy flood (goal >= 0.95).

    python bench/lcm_flood.py --json out/bench/lcm_flood.json [--seconds 4 --rate 75000]
"""

from __future__ import annotations

import argparse
import json
import os
import random
import shlex
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from lcm_loop import ROOT, SETUP, _unshare  # this folder's LCM bench: the same namespace set-up

DECOY = "SPARC_FLOOD_DECOY"
CHANNELS = ("SPARC_HEARTBEAT_ROBOT", "SPARC_TORSO_STATE", "SPARC_SPINE_COMMAND")


def flood(channel: str, rate: float, stop_file: Path, out: Path) -> int:
    """Random payloads on `channel` at `rate` msg/s until `stop_file` exists; writes the count sent."""
    import lcm

    lc = lcm.LCM()
    rng = random.Random(1)
    pool = [rng.randbytes(rng.choice((0, 7, 8, 41, 120))) for _ in range(4096)]
    sent, t0, k = 0, time.monotonic(), 0
    while True:
        now = time.monotonic()
        due = int((now - t0) * rate)
        while sent < due:
            try:
                lc.publish(channel, pool[sent & 4095])
            except OSError:
                pass  # a full socket buffer: the flood is as fast as the host lets it be
            sent += 1
        k += 1
        if k % 64 == 0 and stop_file.exists():
            break
        time.sleep(0.001)
    out.write_text(json.dumps({"sent": sent, "seconds": time.monotonic() - t0}))
    return 0


def run_case(channel: str, seconds: float, rate: float, d: Path) -> dict:
    import numpy as np

    from spine_module.messages import Fault

    py, me = shlex.quote(sys.executable), shlex.quote(str(Path(__file__).resolve()))
    tag = channel.lower()
    stop = d / f"{tag}.stop"
    script = f"""set -e
{SETUP}export PYTHONPATH={shlex.quote(str(ROOT))}
trap 'touch {stop}' EXIT
{py} {me} --role flood --channel {channel} --rate {rate} --stop {stop} --out {d}/{tag}_flood.json &
FLOOD=$!
{py} -m sparc_quad spine-node --clock realtime --rate 1000 --summary {d}/{tag}_node.json > /dev/null \
    2> {d}/{tag}_node.err &
NODE=$!
{py} -m sparc_quad bench-robot --clock realtime --experiment hold --duration {seconds} --out {d}/{tag} \
    > /dev/null 2> {d}/{tag}_robot.err
kill -TERM $NODE
NODE_RC=0
wait $NODE || NODE_RC=$?
echo $NODE_RC > {d}/{tag}_node.rc
touch {stop}
wait $FLOOD
"""
    r = subprocess.run([*_unshare(), "sh", "-c", script], cwd=ROOT, capture_output=True, text=True,
                       timeout=600)
    if r.returncode != 0:
        errs = "\n".join(f"--- {p.name}\n{p.read_text()[-2000:]}" for p in d.glob(f"{tag}*.err"))
        raise SystemExit(f"flood case {channel} failed (rc {r.returncode}):\n{r.stderr}\n{errs}")
    node = json.loads((d / f"{tag}_node.json").read_text())
    # the robot ends first: a node still running then latches HEARTBEAT_LOST and exits 3, which is expected
    node_rc = int((d / f"{tag}_node.rc").read_text())
    if node_rc not in (0, 3) or (node_rc == 3 and node.get("ended_latched") != "HEARTBEAT_LOST"):
        raise SystemExit(f"flood case {channel}: the node exited {node_rc} ({node.get('ended_latched')})")
    robot = json.loads((d / tag / "summary.json").read_text())
    sent = json.loads((d / f"{tag}_flood.json").read_text())
    a = np.load(d / tag / "bench_robot.npz")
    faults = a["node_faults"].astype(np.int64)
    seen = faults[np.flatnonzero(faults != int(Fault.WAITING))[0]:] if (faults != int(Fault.WAITING)).any() \
        else faults
    return {"channel": channel, "achieved_rate_hz": node["achieved_rate_hz"], "ticks": node["ticks"],
            "latched": robot["latched"], "robot_ticks": int(faults.size),
            "ticks_heartbeat_lost": int((seen & int(Fault.HEARTBEAT_LOST) != 0).sum()),
            "ticks_torso_stale": int((seen & int(Fault.TORSO_STALE) != 0).sum()),
            "refused": node.get("rejected_by_channel", {}).get(channel, 0), "refused_total": node["rejected"],
            "flood_sent": sent["sent"], "flood_rate_hz": sent["sent"] / max(sent["seconds"], 1e-9)}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--role", choices=("bench", "flood"), default="bench")
    ap.add_argument("--channel", default=DECOY)
    ap.add_argument("--channels", default=",".join(CHANNELS), help="bench: flooded channels, in turn")
    ap.add_argument("--rate", type=float, default=75_000.0, help="flood messages per second")
    ap.add_argument("--seconds", type=float, default=4.0, help="robot run per case, s")
    ap.add_argument("--stop", type=Path)
    ap.add_argument("--out", type=Path)
    ap.add_argument("--json", type=Path, help="bench: write the result here too")
    args = ap.parse_args()
    if args.role == "flood":
        return flood(args.channel, args.rate, args.stop, args.out)
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        base = run_case(DECOY, args.seconds, args.rate, d)
        cases = [run_case(ch, args.seconds, args.rate, d) for ch in args.channels.split(",") if ch]
    for c in cases:
        c["rate_ratio"] = c["achieved_rate_hz"] / base["achieved_rate_hz"]
    res = {"decoy": base, "flooded": cases, "loadavg": os.getloadavg(), "rate_msgs_per_s": args.rate,
           "note": "shared 2-core machine: rate ratios are the headline, absolute rates depend on load"}
    text = json.dumps(res, indent=1)
    print(text)
    if args.json:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(text + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
