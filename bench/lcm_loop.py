"""The spine node's round trip over LCM, against a bare LCM ping-pong of the same message sizes, in the
same run; and the rates achieved in real-time mode.

Everything runs as separate processes talking UDP multicast inside a private network namespace (made
with `unshare`, as the tests do):

1. lockstep: `bench-robot --clock lockstep` + `spine-node --clock lockstep`. Round trip = wall time from
   the robot publishing a tick's motor feedback to receiving the node's motor command for it (the torso
   state of the tick went out just before). Per tick the node decodes torso + feedback, runs safety and
   the impedance controller, publishes motor command + spine state (+ a heartbeat every 10 ms).
2. bare: a pinger publishes messages of the torso-state and motor-feedback sizes; a ponger answers the
   second with messages of the motor-command and spine-state sizes; round trip = the same interval.
   Ratio = node median / bare median: what the node costs on top of LCM itself.
3. real time: `bench-robot --clock realtime` + `spine-node --clock realtime --rate 1000` holding the
   spine for a few seconds: achieved rates, the node's worst period jitter, ticks the robot stepped
   without a fresh command.
4. bound: `sparc-quad bound --lcm` + `spine-node --motors lcm --clock lockstep` against the
   same bound in process (`run_bound`, default spine), same robot, same simulated seconds, best of
   `--bound-repeat` each, alternating. Headline `lcm_lockstep_over_in_process` = in-process wall / LCM
   lockstep wall (goal >= 0.5) with both commands' defaults except the URL: the co-simulation's
   `channels.COSIM_URL` (LCM's multi-port provider) on both sides. Beside it, the same with the default
   `udpm` URL (`lcm_lockstep_udpm_*`) and with both sides polling 1000 us before they block
   (`--spin-us`, for peers on CPUs of their own; `lcm_lockstep_spin_*`), and with the robot also receiving
   the node's 1 kHz spine states (`bound --lcm-node-states`, off by default; `lcm_lockstep_node_states_*`).
   The commands' defaults hold the
   CPUs' wake latency at 0 us (PM QoS) while they run, where the user may (root); `wake_latency_held`
   says whether it was. The two processes are pinned to two different CPUs (`taskset`), as a node on its
   own torso computer would be: unpinned, Linux wakes the node on the robot's CPU (wake-affine) and the
   two alternate on one core. One unpinned run is reported beside it (`--no-unpinned` skips it). The
   LCM run's trajectory is checked against the node ticked in process (max |difference| reported).

    python bench/lcm_loop.py --json out/bench/lcm_loop.json [--bound-s 5 --bound-repeat 3]
"""

from __future__ import annotations

import argparse
import json
import os
import shlex
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SETUP = "ip link set lo up multicast on && ip route add 224.0.0.0/4 dev lo\n"
PING, PONG = "BENCH_PING", "BENCH_PONG"


def _sizes() -> dict[str, int]:
    import numpy as np

    from spine_module.buses.base import MotorCommand, MotorFeedback
    from spine_module.messages import SpineState, TorsoState, codec

    fb = MotorFeedback(q=np.zeros(3), dq=np.zeros(3), tau=np.zeros(3))
    return {"torso": len(codec.encode_torso(TorsoState())), "feedback": len(codec.encode_motor_feedback(fb)),
            "command": len(codec.encode_motor_command(MotorCommand.zero())),
            "state": len(codec.encode_state(SpineState()))}


def pong(n: int) -> int:
    import lcm

    sizes = _sizes()
    lc = lcm.LCM()
    cmd, state = bytes(sizes["command"]), bytes(sizes["state"])
    count = [0]

    def on_ping(channel: str, data: bytes) -> None:
        if len(data) == sizes["feedback"]:  # the second of the pair, as the node answers the feedback
            lc.publish(PONG, cmd)
            lc.publish(PONG + "_STATE", state)
            count[0] += 1

    lc.subscribe(PING, on_ping)
    deadline = time.monotonic() + 120
    while count[0] < n and time.monotonic() < deadline:
        lc.handle_timeout(100)
    return 0


def ping(n: int, out: Path) -> int:
    import lcm

    sizes = _sizes()
    lc = lcm.LCM()
    got = [False]
    lc.subscribe(PONG, lambda c, d: got.__setitem__(0, True))
    torso, fb = bytes(sizes["torso"]), bytes(sizes["feedback"])
    time.sleep(0.5)  # let the ponger subscribe
    rtts = []
    for _ in range(n + 100):
        got[0] = False
        lc.publish(PING, torso)
        t0 = time.perf_counter()
        lc.publish(PING, fb)
        while not got[0]:
            if lc.handle_timeout(200) <= 0:  # a lost datagram: counted as a 200 ms round trip
                break
        rtts.append(time.perf_counter() - t0)
    out.write_text(json.dumps({"rtt_s": rtts[100:], "sizes": sizes}))
    return 0


def _unshare() -> list[str]:
    for prefix in (["unshare", "-rn"], ["unshare", "-n"]):
        if subprocess.run([*prefix, "sh", "-c", SETUP], capture_output=True).returncode == 0:
            return prefix
    raise SystemExit("cannot create a network namespace (unshare) here")


def _pin_cpus() -> tuple[int, int] | None:
    """Two CPUs this process may use (node, robot), or None (one CPU, or no `taskset`)."""
    cpus = sorted(os.sched_getaffinity(0))
    if len(cpus) < 2 or shutil.which("taskset") is None:
        return None
    return cpus[-1], cpus[0]


def lcm_bound(duration_s: float, pin: tuple[int, int] | None, keep: Path | None = None,
              spin_us: float | None = None, url: str | None = None, node_states: bool = False) -> float:
    """Wall time of `run_bound` in the robot process (its metrics' `wall_time_s`) of a `bound --lcm` run
    against a lockstep spine node, two processes in a network namespace; `keep`: copy its CSV there;
    `spin_us`: both sides' lockstep poll before blocking; `url`: both sides' LCM URL (None: the commands'
    defaults); `node_states`: the robot also receives the node's spine states (`--lcm-node-states`)."""
    py = shlex.quote(sys.executable)
    node_pin, robot_pin = (f"taskset -c {pin[0]} ", f"taskset -c {pin[1]} ") if pin else ("", "")
    node_spin = robot_spin = ""
    if spin_us is not None:
        node_spin, robot_spin = f"--spin-us {spin_us:g} ", f"--lcm-spin-us {spin_us:g} "
    if url is not None:
        node_spin += f"--lcm-url {shlex.quote(url)} "
        robot_spin += f"--lcm-url {shlex.quote(url)} "
    if node_states:
        robot_spin += "--lcm-node-states "
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        script = (f"set -e\n{SETUP}export PYTHONPATH={shlex.quote(str(ROOT))}\n"
                  f"{node_pin}{py} -m sparc_quad spine-node --motors lcm --clock lockstep {node_spin}"
                  "--idle-timeout 3 "
                  f"--summary {d}/node.json > /dev/null 2> {d}/node.err &\nNODE=$!\n"
                  f"{robot_pin}{py} -m sparc_quad bound --lcm {robot_spin}--no-plots --duration {duration_s} "
                  f"--out {d}/bound > /dev/null 2> {d}/robot.err\nwait $NODE\n")
        r = subprocess.run([*_unshare(), "sh", "-c", script], cwd=ROOT, capture_output=True, text=True,
                           timeout=600)
        metrics = d / "bound" / "metrics.json"
        if r.returncode != 0 or not metrics.exists():
            errs = "\n".join(f"--- {p.name}\n{p.read_text()[-2000:]}" for p in d.glob("*.err"))
            raise SystemExit(f"LCM bound failed (rc {r.returncode}):\n{r.stderr}\n{errs}")
        ticks = json.loads((d / "node.json").read_text())["ticks"]
        if ticks != round(duration_s * 1000):
            raise SystemExit(f"LCM bound: the node ticked {ticks} times for {duration_s} s")
        if keep is not None:
            shutil.copy(d / "bound" / "timeseries.csv", keep)
        return float(json.loads(metrics.read_text())["wall_time_s"])


def bound_legs(duration_s: float, repeat: int, unpinned: bool) -> dict:
    """In-process bound against the same bound over LCM lockstep, alternating, best of `repeat`."""
    import numpy as np

    from sparc_quad.bound.run import BoundConfig, run_bound
    from sparc_quad.robot_side.quad import NodeSpine
    from sparc_quad.sim.bound_log import COLUMNS
    from spine_module.buses.lcm import DEDICATED_CPU_SPIN_S
    from spine_module.messages.channels import COSIM_URL

    pin = _pin_cpus()
    cfg = BoundConfig(duration_s=duration_s)
    inproc, lcm_pinned, lcm_udpm, lcm_free, lcm_spin, lcm_states = [], [], [], [], [], []
    with tempfile.TemporaryDirectory() as tmp:
        csv = Path(tmp) / "lcm.csv"
        for i in range(repeat):
            inproc.append(run_bound(cfg).wall_s)
            lcm_pinned.append(lcm_bound(duration_s, pin, keep=csv if i == 0 else None, url=COSIM_URL))
            lcm_udpm.append(lcm_bound(duration_s, pin))
            lcm_spin.append(lcm_bound(duration_s, pin, spin_us=DEDICATED_CPU_SPIN_S * 1e6, url=COSIM_URL))
            lcm_states.append(lcm_bound(duration_s, pin, url=COSIM_URL, node_states=True))
        if unpinned and pin is not None:
            lcm_free.append(lcm_bound(duration_s, None, url=COSIM_URL))
        lcm_series = np.loadtxt(csv, delimiter=",", skiprows=1)
    ref = run_bound(cfg, spine=NodeSpine.inprocess(cfg.spine)).series
    cols = [COLUMNS.index(c) for c in ("x", "z", "q1_true", "q2", "q3", "q4", "tau2", "tau3", "tau4")]
    diff = float(np.max(np.abs(lcm_series[:, cols] - ref[:, cols]))) if lcm_series.shape == ref.shape \
        else float("inf")
    best_in, best_lcm = min(inproc), min(lcm_pinned)
    return {
        "bound_sim_s": duration_s, "bound_repeat": repeat,
        "in_process_bound_wall_s": best_in,
        "lcm_lockstep_bound_wall_s": best_lcm,
        "lcm_lockstep_over_in_process": best_in / best_lcm,
        "lcm_url": COSIM_URL,
        "wake_latency_held": _wake_latency_allowed(),
        "lcm_lockstep_udpm_bound_wall_s": min(lcm_udpm),
        "lcm_lockstep_udpm_over_in_process": best_in / min(lcm_udpm),
        "lcm_lockstep_spin_us": DEDICATED_CPU_SPIN_S * 1e6,
        "lcm_lockstep_spin_over_in_process": best_in / min(lcm_spin),
        "lcm_lockstep_node_states_bound_wall_s": min(lcm_states),
        "lcm_lockstep_node_states_over_in_process": best_in / min(lcm_states),
        "lcm_lockstep_us_per_tick_over_in_process": 1e6 * (best_lcm - best_in) / round(duration_s * 1000),
        "lcm_pinned_cpus_node_robot": list(pin) if pin else None,
        "lcm_lockstep_unpinned_wall_s": min(lcm_free) if lcm_free else None,
        "lcm_lockstep_unpinned_over_in_process": best_in / min(lcm_free) if lcm_free else None,
        "lcm_vs_node_in_process_max_abs_diff": diff,
        "bound_all_runs_s": {"in_process": inproc, "lcm_lockstep": lcm_pinned, "lcm_lockstep_udpm": lcm_udpm,
                             "lcm_lockstep_spin": lcm_spin, "lcm_lockstep_node_states": lcm_states,
                             "lcm_unpinned": lcm_free},
    }


def _wake_latency_allowed() -> bool:
    """Whether the commands' default wake-latency request can be held here (PM QoS needs root)."""
    from spine_module.node.realtime import CPU_DMA_LATENCY

    return os.access(CPU_DMA_LATENCY, os.W_OK)


def _stats_us(xs: list[float]) -> dict[str, float]:
    xs = sorted(xs)
    return {"median_us": 1e6 * statistics.median(xs), "p90_us": 1e6 * xs[int(0.9 * (len(xs) - 1))],
            "p99_us": 1e6 * xs[int(0.99 * (len(xs) - 1))], "n": len(xs)}


def transport_legs(args: argparse.Namespace) -> dict:
    """Sections 1-3: lockstep round trip, bare LCM ping-pong, real time."""
    import numpy as np

    py, me = shlex.quote(sys.executable), shlex.quote(str(Path(__file__).resolve()))
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        dur = args.ticks / 1000.0
        script = f"""set -e
{SETUP}export PYTHONPATH={shlex.quote(str(ROOT))}
N="{py} -m sparc_quad spine-node"
R="{py} -m sparc_quad bench-robot"
# 1. node in lockstep
$N --clock lockstep --idle-timeout 2 --summary {d}/ls_node.json > /dev/null 2> {d}/ls_node.err &
NODE=$!
$R --clock lockstep --experiment hold --duration {dur} --out {d}/ls > /dev/null 2> {d}/ls_robot.err
wait $NODE
# 2. bare ping-pong
{py} {me} --role pong --ticks {args.ticks} &
PONG=$!
{py} {me} --role ping --ticks {args.ticks} --out {d}/bare.json
wait $PONG
# 3. real time: the node runs until the robot is done, then gets SIGTERM
$N --clock realtime --rate 1000 --summary {d}/rt_node.json > /dev/null 2> {d}/rt_node.err &
NODE=$!
$R --clock realtime --experiment hold --duration {args.realtime_s} --out {d}/rt >/dev/null 2>{d}/rt_robot.err
kill -TERM $NODE
# a node still running after the robot ended has latched HEARTBEAT_LOST and exits 3: expected here
wait $NODE || [ $? -eq 3 ]
"""
        r = subprocess.run([*_unshare(), "sh", "-c", script], cwd=ROOT, capture_output=True, text=True,
                           timeout=600)
        if r.returncode != 0:
            errs = "\n".join(f"--- {p.name}\n{p.read_text()[-2000:]}" for p in d.glob("*.err"))
            raise SystemExit(f"benchmark failed (rc {r.returncode}):\n{r.stderr}\n{errs}")
        ls = np.load(d / "ls" / "bench_robot.npz")
        node_rtt = [float(x) for x in ls["robot_rtt_s"][100:]]
        bare = json.loads((d / "bare.json").read_text())
        rt_node = json.loads((d / "rt_node.json").read_text())
        if rt_node.get("ended_latched") not in (None, "", "HEARTBEAT_LOST"):  # exit 3 accepted for that one
            raise SystemExit(f"real time: the node ended latched {rt_node['ended_latched']}")
        rt_robot = json.loads((d / "rt" / "summary.json").read_text())
        rt = np.load(d / "rt" / "bench_robot.npz")
        ls_node = json.loads((d / "ls_node.json").read_text())

    node_s, bare_s = _stats_us(node_rtt), _stats_us(bare["rtt_s"])
    answered = rt["robot_answered"].astype(bool)
    period = rt["node_period"][rt["node_faults"] == 0]  # node ticks while the robot was up and all was well
    period = period[period > 0]
    return {
        "message_bytes": bare["sizes"],
        "lockstep_node_rtt": node_s,
        "bare_lcm_rtt": bare_s,
        "rtt_ratio_node_over_bare_median": node_s["median_us"] / bare_s["median_us"],
        "lockstep_ticks_per_s": ls_node["ticks"] / ls_node["elapsed_wall_s"],
        "realtime_node_rate_hz_while_robot_up": float(1.0 / np.mean(period)) if period.size else None,
        "realtime_node_period_p99_s": float(np.quantile(period, 0.99)) if period.size else None,
        "realtime_node_rate_hz_whole_run": rt_node["achieved_rate_hz"],
        "realtime_node_jitter_max_s": rt_node["jitter_max_s"],
        "realtime_node_overruns": rt_node["overruns"],
        "realtime_robot_rate_hz": rt_robot["achieved_rate_hz"],
        "realtime_robot_ticks_without_fresh_command": int((~answered).sum()),
        "realtime_robot_ticks": int(answered.size),
        "note": "shared 2-core machine; lockstep_ticks_per_s includes start-up and the 2 s idle timeout",
    }


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--json", type=Path, help="write the results here")
    ap.add_argument("--ticks", type=int, default=3000, help="lockstep ticks and ping-pongs (default: 3000)")
    ap.add_argument("--realtime-s", type=float, default=3.0, help="real-time run length, s (default: 3)")
    ap.add_argument("--bound-s", type=float, default=5.0, help="bound legs: simulated s (5; 0 skips)")
    ap.add_argument("--bound-repeat", type=int, default=3, help="bound legs: runs each, best kept (3)")
    ap.add_argument("--no-unpinned", action="store_true", help="bound legs: skip the unpinned LCM run")
    ap.add_argument("--only-bound", action="store_true", help="run only the bound legs (section 4)")
    ap.add_argument("--role", choices=["ping", "pong"], help=argparse.SUPPRESS)
    ap.add_argument("--out", type=Path, help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.role == "pong":
        return pong(args.ticks + 100)  # the pinger warms up with 100 extra rounds
    if args.role == "ping":
        return ping(args.ticks, args.out)

    result: dict = {}
    if not args.only_bound:
        result.update(transport_legs(args))
    if args.bound_s > 0:
        result.update(bound_legs(args.bound_s, args.bound_repeat, not args.no_unpinned))
    from bench_io import emit, host_facts  # here: the ping/pong roles need no pinocchio

    result.update(host_facts())
    emit(result, args.json, width=44)
    return 0


if __name__ == "__main__":
    sys.exit(main())
