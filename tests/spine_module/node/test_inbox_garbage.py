"""Garbage on the node's input channels is refused at a first look (fingerprint) and counted per channel;
valid messages between the garbage all get through."""

from __future__ import annotations

import random

from spine_module.messages import FingerprintError, Heartbeat, SpineCommand, TorsoState, channels, codec
from spine_module.node.io import Inbox

VALID = {
    channels.TORSO_STATE: lambda k: codec.encode_torso(TorsoState(stamp_s=k * 1e-3, seq=k)),
    channels.SPINE_COMMAND: lambda k: codec.encode_command(SpineCommand(stamp_s=k * 1e-3, seq=k)),
    channels.HEARTBEAT_ROBOT: lambda k: codec.encode_heartbeat(Heartbeat("robot", False, 0, k * 1e-3, k)),
}


def test_random_bytes_are_refused_and_counted_per_channel_valid_ones_pass():
    rng = random.Random(7)
    inbox = Inbox()
    garbage_per_tick = 50
    for k in range(1, 201):
        for ch, make in VALID.items():
            for _ in range(garbage_per_tick):
                inbox.offer_bytes(ch, rng.randbytes(rng.choice((0, 3, 8, 40, 120))))
            inbox.offer_bytes(ch, make(k))
            for _ in range(garbage_per_tick):
                inbox.offer_bytes(ch, rng.randbytes(rng.choice((0, 3, 8, 40, 120))))
        torso, command, heartbeat, _reset, rejects = inbox.take()
        assert (torso.seq, command.seq, heartbeat.seq) == (k, k, k)
        assert rejects and all(isinstance(r, FingerprintError) for r in rejects)
    assert inbox.rejected == dict.fromkeys(VALID, 200 * 2 * garbage_per_tick)


def test_a_message_of_another_sparc_type_is_still_named():
    inbox = Inbox()
    inbox.offer_bytes(channels.HEARTBEAT_ROBOT, VALID[channels.TORSO_STATE](1))
    (rej,) = inbox.take()[4]
    assert "sparc.torso_state_t" in str(rej) and inbox.rejected[channels.HEARTBEAT_ROBOT] == 1
