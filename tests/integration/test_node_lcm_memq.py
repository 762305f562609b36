"""The LCM path in one process (memq://): LCM motor bus + LCM node IO against the LCM robot port, in
lockstep, reproduces the in-process run exactly; malformed feedback on the wire is rejected by name."""

from __future__ import annotations

import lcm
import numpy as np

from sparc_quad.experiments.scripts import static_push_script
from sparc_quad.robot_side.bench import BenchRobot, run_inprocess
from sparc_quad.robot_side.ports import LcmPort
from sparc_quad.sim.bench_world import BenchWorld
from spine_module.buses.base import MotorBusError, MotorFeedback
from spine_module.buses.lcm import LcmMotorBus
from spine_module.messages import Fault, SpineState, TorsoState, channels, codec
from spine_module.node import Controllers, LcmNodeIO, NodeConfig, SpineNode

N = 300


def _script():
    return static_push_script(k_x=400.0, amplitude_m=0.02, period_s=0.3, cycles=1.0)


def test_lockstep_over_lcm_memq_equals_inprocess():
    ref_robot, ref_states = run_inprocess(_script(), NodeConfig(), n_ticks=N)
    lc = lcm.LCM("memq://")
    node = SpineNode(Controllers.default(), LcmMotorBus(lc=lc), LcmNodeIO(lc), NodeConfig())
    port = LcmPort(lc=lc)
    with BenchWorld() as world:
        robot = BenchRobot(world, port, _script())
        for _ in range(N):
            robot.publish_tick()
            fb = node.receive(0.0)
            assert fb is not None and fb.seq == robot.k
            node.tick(fb.stamp_s, fb)
            robot.finish_tick(port.take_command(0.0, want_seq=robot.k))
    while lc.handle_timeout(0) > 0:
        pass
    q_lcm, q_ref = np.array(robot.log.q), np.array(ref_robot.log.q)
    assert np.max(np.abs(q_lcm - q_ref)) <= 1e-12
    assert len(port.states) == N == len(ref_states)
    np.testing.assert_array_equal([s.tau_cmd for s in port.states], [s.tau_cmd for s in ref_states])
    # the law's own clamp cuts the torque on some ticks of this fast (0.3 s) push-pull: TORQUE_CLAMPED since
    # issue 31 (before, only the output stage's clamp raised it, and it never saw a torque beyond the limit)
    noisy = Fault.JOINT_LIMIT | Fault.TORQUE_CLAMPED
    assert robot.unanswered == 0 and not any(s.faults & ~noisy for s in port.states[1:])
    assert [s.faults for s in port.states] == [s.faults for s in ref_states]


def test_lcm_bus_rejects_malformed_feedback_by_field():
    lc = lcm.LCM("memq://")
    bus = LcmMotorBus(lc=lc)
    raw = codec.decode_raw(channels.MOTOR_FEEDBACK, codec.encode_motor_feedback(
        MotorFeedback(q=np.zeros(3), dq=np.zeros(3), tau=np.zeros(3))))
    raw.velocity = [0.0, float("nan"), 0.0]
    lc.publish(channels.MOTOR_FEEDBACK, raw.encode())
    try:
        bus.receive(0.01)
    except MotorBusError as exc:
        assert "SPARC_MOTOR_FEEDBACK.velocity[1]: NaN" in str(exc)
    else:
        raise AssertionError("malformed feedback was accepted")
    lc.publish(channels.MOTOR_FEEDBACK, codec.encode_torso(TorsoState()))
    try:
        bus.receive(0.01)
    except MotorBusError as exc:
        assert "wrong fingerprint" in str(exc) and "sparc.torso_state_t" in str(exc)
    else:
        raise AssertionError("wrong-fingerprint feedback was accepted")


def test_lcm_port_keeps_state_bytes_and_counts_a_malformed_state_when_read():
    lc = lcm.LCM("memq://")
    port = LcmPort(lc=lc)
    good = SpineState(seq=7, q=np.array([0.1, 0.2, 0.3, 0.4]))
    lc.publish(channels.SPINE_STATE, codec.encode_state(good))
    lc.publish(channels.SPINE_STATE, codec.encode_torso(TorsoState()))  # wrong type on the state channel
    port.node_heartbeats()  # the 1 kHz loop's drain: bytes kept, nothing decoded yet
    assert port._states == [] and len(port._raw_states) == 2
    assert [s.seq for s in port.states] == [7] and port.rejected == 1
    np.testing.assert_array_equal(port.states[0].q, good.q)


def test_reading_lcm_port_rejected_decodes_nothing():
    lc = lcm.LCM("memq://")
    port = LcmPort(lc=lc)
    bad_hb = codec.decode_raw(channels.HEARTBEAT_NODE, codec.encode_heartbeat(codec.Heartbeat("node")))
    bad_hb.seq = -1
    lc.publish(channels.HEARTBEAT_NODE, bad_hb.encode())  # rejected as it arrives
    lc.publish(channels.SPINE_STATE, codec.encode_torso(TorsoState()))  # rejected when `states` decodes it
    lc.publish(channels.SPINE_STATE, codec.encode_state(SpineState(seq=3)))
    assert port.node_heartbeats() == []
    first = port.rejected
    assert first == 1 and port.rejected == first  # the heartbeat; reading `rejected` again changes nothing
    assert port._states == [] and len(port._raw_states) == 2  # reading `rejected` decoded no state
    assert [s.seq for s in port.states] == [3] and port.rejected == 2
    assert [s.seq for s in port.states] == [3] and port.rejected == 2  # each state decoded and counted once


def test_a_node_spine_over_lcm_receives_the_node_states_only_when_asked():
    from sparc_quad.robot_side.quad import NodeSpine
    from sparc_quad.sim.spine_drive import SpineGains

    gains = SpineGains()
    for asked in (False, True):
        lc = lcm.LCM("memq://")
        spine = NodeSpine(LcmPort(lc=lc, keep_states=asked), gains)
        lc.publish(channels.SPINE_STATE, codec.encode_state(SpineState(seq=3)))
        while lc.handle_timeout(0) > 0:
            pass
        assert spine.records_states is asked
        states = spine.node_states()
        if asked:
            assert states["node_seq"].tolist() == [3]
        else:
            assert states is None and spine.port._raw_states == []  # never subscribed
        spine.close()
