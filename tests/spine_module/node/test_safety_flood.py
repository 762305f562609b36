"""A command flood cannot stall the node's loop.

Thousands of spine commands queued on the node's LCM handle (memq://, one process) ahead of the motor
feedback: every receive() and every input poll dispatches at most its bound, only the newest command is
used (the rest are counted as dropped), and every lockstep tick is still answered."""

from __future__ import annotations

import lcm
import numpy as np

from spine_module import params
from spine_module.buses.lcm import MAX_MESSAGES_PER_RECEIVE, LcmMotorBus
from spine_module.messages import Heartbeat, Mode, MotorFeedback, SpineCommand, TorsoState, channels, codec
from spine_module.node import Controllers, LcmNodeIO, NodeConfig, SpineNode
from spine_module.node.io import MAX_MESSAGES_PER_POLL

FLOOD = 1000  # commands queued ahead of each of ten feedback ticks
TICKS = 60


def test_command_flood_is_bounded_per_tick_and_lockstep_keeps_going():
    lc = lcm.LCM("memq://")
    bus, io = LcmMotorBus(lc=lc), LcmNodeIO(lc)
    node = SpineNode(Controllers.default(), bus, io, NodeConfig())
    answers: list[int] = []  # feedback seq each motor command answers
    lc.subscribe(channels.MOTOR_COMMAND, lambda ch, data: answers.append(codec.decode_motor_command(data)[1]))
    q0 = params.Q_EQUILIBRIUM[1:]  # q2..q4 at the paper's equilibrium arch
    handled_receive, handled_poll, empty_receives = [], [], 0
    for k in range(1, TICKS + 1):
        t = k * 1e-3
        lc.publish(channels.TORSO_STATE, codec.encode_torso(TorsoState(stamp_s=t, seq=k)))
        lc.publish(channels.HEARTBEAT_ROBOT, codec.encode_heartbeat(Heartbeat("robot", False, 0, t, k)))
        lc.publish(channels.SPINE_COMMAND, codec.encode_command(SpineCommand(stamp_s=t, seq=k)))
        if 30 <= k < 40:  # the flood, ahead of the feedback; the very last command asks for PD
            for i in range(FLOOD):
                last = k == 39 and i == FLOOD - 1
                cmd = SpineCommand(mode=Mode.PD if last else Mode.IMPEDANCE, seq=10_000 + k * FLOOD + i)
                lc.publish(channels.SPINE_COMMAND, codec.encode_command(cmd))
        lc.publish(channels.MOTOR_FEEDBACK, codec.encode_motor_feedback(MotorFeedback(
            q=q0, dq=np.zeros(3), tau=np.zeros(3), stamp_s=t, seq=k)))
        while (fb := node.receive(0.0)) is None:  # what run_lockstep does, call after call
            handled_receive.append(bus.handled_last)
            empty_receives += 1
            assert empty_receives < 100 * FLOOD // MAX_MESSAGES_PER_RECEIVE
        handled_receive.append(bus.handled_last)
        assert fb.seq == k
        node.tick(fb.stamp_s, fb)
        handled_poll.append(io.handled_last_poll)
        while not answers or answers[-1] != k:  # the robot waits for the answer to its tick
            assert lc.handle_timeout(0) > 0, f"tick {k} not answered"
    assert max(handled_receive) <= MAX_MESSAGES_PER_RECEIVE and max(handled_poll) <= MAX_MESSAGES_PER_POLL
    assert empty_receives >= 10 * (FLOOD // MAX_MESSAGES_PER_RECEIVE)  # the flood was really in the way
    assert answers == list(range(1, TICKS + 1))  # every lockstep tick answered, once, in order
    dropped = io.inbox.dropped[channels.SPINE_COMMAND]
    assert dropped >= 10 * FLOOD - 10  # superseded before the node looked
    assert node.state.requested_mode in (Mode.PD, Mode.IMPEDANCE)
    assert np.all(np.isfinite(node.state.tau_cmd))
