"""Issue 31: sequence numbers that go back, repeat or jump were used as fresh, uncounted.

`torso_state_t.seq` is "+1 per message". Every input channel counts anomalies (`Inbox.seq_anomalies`); the
torso state (one producer, this tick's q1) refuses repeats and steps back, so a frozen estimator resending
byte-identical states goes TORSO_STALE at its 20 ms deadline (before: IMPEDANCE on the frozen q1 for the
whole 0.5 s); a restarted estimator is followed after SEQ_RESYNC in-order messages; commands are only
counted (an E-stop from a fresh `spine-cmd` starts at seq 0 and must act).
"""

from __future__ import annotations

from spine_module import params as P
from spine_module.messages import Fault, Mode, SpineCommand, TorsoState, channels, codec
from spine_module.node.io import SEQ_RESYNC, Inbox
from tests.node_harness import DT, Harness


def test_frozen_estimator_goes_torso_stale():
    h = Harness()
    h.step(600)
    assert h.states[-1].mode == Mode.IMPEDANCE
    frozen = TorsoState(q1=0.1, stamp_s=h.t, seq=h.k)
    h.send_torso = False
    t0 = h.t
    h.step(60, extra=lambda hh: hh.io.send_torso(frozen))  # the same bytes every tick
    stale = h.first(lambda s: s.faults & Fault.TORSO_STALE, after=t0)
    assert stale is not None and stale.mode == Mode.DAMPING
    assert stale.stamp_s - t0 <= P.SAFETY.torso_deadline_s + 2 * DT
    assert h.io.inbox.seq_anomalies[channels.TORSO_STATE]["repeat"] >= 55


def test_torso_steps_back_are_refused_until_a_restart_is_clear():
    box = Inbox()
    for seq in (10, 11, 12):
        box.offer_bytes(channels.TORSO_STATE, codec.encode_torso(TorsoState(seq=seq)))
    assert box.take()[0].seq == 12
    box.offer_bytes(channels.TORSO_STATE, codec.encode_torso(TorsoState(seq=5)))  # a replay
    assert box.take()[0] is None
    for seq in range(SEQ_RESYNC):  # the estimator restarted at 0
        box.offer_bytes(channels.TORSO_STATE, codec.encode_torso(TorsoState(seq=seq)))
    assert box.take()[0].seq == SEQ_RESYNC - 1
    box.offer_bytes(channels.TORSO_STATE, codec.encode_torso(TorsoState(seq=40)))  # lost messages
    assert box.take()[0].seq == 40
    counts = box.seq_anomalies[channels.TORSO_STATE]
    assert counts == {"backwards": 1 + SEQ_RESYNC, "repeat": 0, "jump": 1}


def test_commands_are_counted_never_refused():
    box = Inbox()
    box.offer_bytes(channels.SPINE_COMMAND, codec.encode_command(SpineCommand(mode=Mode.DAMPING, seq=100)))
    box.take()
    box.offer_bytes(channels.SPINE_COMMAND, codec.encode_command(SpineCommand(mode=Mode.ESTOP, seq=0)))
    assert box.take()[1].mode == Mode.ESTOP
    assert box.seq_anomalies[channels.SPINE_COMMAND]["backwards"] == 1
