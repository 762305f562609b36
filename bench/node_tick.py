"""Cost of one spine-node tick in process against one raw pinocchio RNEA call, in the same run.

A tick here is what the node does every millisecond on the robot: decode its inputs (torso state and a
spine command every tick, a robot heartbeat every 10th, through the validating codec), take the motor
feedback, run the safety logic, the impedance controller (eq. 3 + 4), and encode its outputs (motor
command, spine state, node heartbeat every 10th tick). The robot side is not timed.

Prints and writes (--json) `node_tick_us`, `rnea_us`, `node_tick_over_rnea` (goal: at most 50) and a
per-stage breakdown: decode, control and encode are timed on the same messages and state outside the
tick; `safety_and_glue_us` is the rest of the tick (watchdogs, clamps, mode logic, bookkeeping).
Times are this thread's CPU time by default (--clock wall for wall time), so other processes on a shared
machine do not land in the numbers. Medians over batches (and the ratio of the fastest batches,
`*_min`), batches interleaved with the rnea reference so machine load hits both alike.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))  # time this checkout's code, not an install

import numpy as np
import pinocchio as pin
from bench_io import emit, host_facts

from spine_module import params as P
from spine_module.buses.base import MotorCommand, MotorFeedback
from spine_module.buses.inprocess import InProcessBus, InProcessLink
from spine_module.messages import Heartbeat, Mode, SpineCommand, TorsoState, channels, codec
from spine_module.node import Controllers, InProcessNodeIO, NodeConfig, SpineNode, realtime
from spine_module.node.io import Inbox

DT = 0.001


CLOCKS = {"cpu": time.thread_time, "wall": time.perf_counter}
clock = time.thread_time


def _batch_us(fn, n: int) -> float:
    t0 = clock()
    for _ in range(n):
        fn()
    return (clock() - t0) / n * 1e6


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--json", type=Path, help="write the results here")
    ap.add_argument("--ticks", type=int, default=6000, help="node ticks timed in total (>= 5000)")
    ap.add_argument("--batches", type=int, default=12)
    ap.add_argument("--clock", choices=tuple(CLOCKS), default="cpu",
                    help="cpu: this thread's CPU time (robust on a shared machine, the default); wall")
    args = ap.parse_args()
    global clock
    clock = CLOCKS[args.clock]
    if args.ticks < 5000 or args.batches < 1:
        ap.error("--ticks must be at least 5000 and --batches at least 1")
    per_batch = max(1, args.ticks // args.batches)

    ctrls = Controllers.default()
    link = InProcessLink()
    io = InProcessNodeIO(keep=16)
    node = SpineNode(ctrls, InProcessBus(link), io, NodeConfig())
    torso_b = codec.encode_torso(TorsoState(q1=0.05, dq1=0.1, ddq1=0.5, ddq1_valid=True, seq=1))
    cmd_b = codec.encode_command(SpineCommand(mode=Mode.IMPEDANCE, seq=1))
    hb_b = codec.encode_heartbeat(Heartbeat("bench-robot", seq=1))
    rng = np.random.default_rng(0)
    q = P.Q_EQUILIBRIUM[1:] + rng.uniform(-0.05, 0.05, 3)
    fb = MotorFeedback(q=q, dq=rng.normal(0.0, 0.2, 3), tau=np.zeros(3), stamp_s=0.0, seq=0)
    robot = link.robot
    k = [0]

    def tick() -> None:
        i = k[0]
        now = i * DT
        io.deliver(channels.TORSO_STATE, torso_b)
        io.deliver(channels.SPINE_COMMAND, cmd_b)
        if i % 10 == 0:
            io.deliver(channels.HEARTBEAT_ROBOT, hb_b)
        node.tick(now, node.receive(0.0), wall_s=now)
        k[0] = i + 1

    def robot_side() -> None:  # untimed: the robot publishes feedback and takes the command
        fb.stamp_s, fb.seq = k[0] * DT, k[0]
        robot.publish_feedback(fb)

    def timed_ticks(n: int) -> float:
        total = 0.0
        for _ in range(n):
            robot_side()
            t0 = clock()
            tick()
            total += clock() - t0
            robot.take_command(0.0)
        return total / n * 1e6

    # stages on the same data, outside the tick
    inbox = Inbox()

    def decode() -> None:
        inbox.offer_bytes(channels.TORSO_STATE, torso_b)
        inbox.offer_bytes(channels.SPINE_COMMAND, cmd_b)
        inbox.take()

    qq, dqq = np.concatenate([[0.05], q]), np.concatenate([[0.1], fb.dq])
    imp = ctrls.impedance
    bus = InProcessBus(InProcessLink())

    def encode() -> None:
        io.publish_state(node.state)
        bus.send(MotorCommand(tau_ff=np.zeros(3), enable=True, stamp_s=0.0, seq=1))

    raw = ctrls.impedance.model.model.createData()
    qa, va, aa = qq.copy(), dqq.copy(), np.ones(4)

    def rnea() -> None:
        pin.rnea(ctrls.impedance.model.model, raw, qa, va, aa)

    # as `spine-node` does once the node is built: the start-up objects (models, modules, compiled code)
    # out of the collector's reach, so the tick's collections walk only what the loop allocates
    frozen = realtime.freeze_startup_objects()
    # warm up past the soft start so the timed ticks run the full impedance law
    for _ in range(int(P.SAFETY.soft_start_s / DT) + 50):
        robot_side()
        tick()
        robot.take_command(0.0)
    if node.state.mode != Mode.IMPEDANCE or node.state.gain_scale < 1.0:
        raise SystemExit(f"bench set-up error: node in {node.state.mode.name}, faults {node.state.faults!r}")
    samples: dict[str, list[float]] = {k_: [] for k_ in
                                       ("node_tick_us", "rnea_us", "decode_us", "control_us", "encode_us")}
    for _ in range(args.batches):
        samples["node_tick_us"].append(timed_ticks(per_batch))
        samples["rnea_us"].append(_batch_us(rnea, 2000))
        samples["decode_us"].append(_batch_us(decode, 500))
        samples["control_us"].append(_batch_us(lambda: imp.step(qq, dqq, 0.5), 1000))
        samples["encode_us"].append(_batch_us(encode, 500))
    res: dict[str, object] = {k_: statistics.median(v) for k_, v in samples.items()}
    # on a shared machine the fastest batch is the best estimate of the CPU cost; both are reported
    res.update({f"{k_}_min": min(v) for k_, v in samples.items() if k_ in ("node_tick_us", "rnea_us")})
    res["node_tick_over_rnea_min"] = res["node_tick_us_min"] / res["rnea_us_min"]
    res["safety_and_glue_us"] = res["node_tick_us"] - res["decode_us"] - res["control_us"] - res["encode_us"]
    res["node_tick_over_rnea"] = res["node_tick_us"] / res["rnea_us"]
    res["goal_node_tick_over_rnea"] = 50.0
    res["ticks"] = per_batch * args.batches
    res["clock"] = args.clock
    res["backend"] = imp.backend
    res["gc"] = frozen
    res.update(host_facts())
    emit(res, args.json)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
