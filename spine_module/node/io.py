"""The node's non-motor side: torso state, spine commands and robot heartbeats in; spine state and the
node's heartbeat out. Every incoming message goes through the validating codec, whatever the transport,
so an in-process run and an LCM run see identical numbers.
"""

from __future__ import annotations

import logging
import time
from collections import deque
from collections.abc import Callable, Iterator, Sequence

import lcm

from spine_module import params
from spine_module.messages import (
    Heartbeat,
    MessageError,
    SpineCommand,
    SpineState,
    TorsoState,
    channels,
    codec,
)
from spine_module.messages.dispatch import dispatch

log = logging.getLogger("spine_module.node")

_INCOMING = {
    channels.TORSO_STATE: codec.decode_torso,
    channels.SPINE_COMMAND: codec.decode_command,
    channels.HEARTBEAT_ROBOT: codec.decode_heartbeat,
}
# Cheap first look: a payload whose 8-byte fingerprint is none of our types (random bytes, a foreign
# publisher) is refused with one slice and two lookups (~0.5 us) instead of a decode that builds and formats
# an error (9-12 us measured at load 7); one shared error object per channel stands for all of them.
_FINGERPRINT = {ch: codec.TYPE_BY_CHANNEL[ch]._get_packed_fingerprint() for ch in _INCOMING}
_KNOWN_FINGERPRINTS = frozenset(cls._get_packed_fingerprint() for cls in codec.LCM_TYPES)
_FOREIGN = {ch: codec.FingerprintError(ch, "", f"not a {codec.type_name(codec.TYPE_BY_CHANNEL[ch])} nor any "
                                               "sparc type (unknown fingerprint or shorter than one)")
            for ch in _INCOMING}


# A flood on one channel must not stall the loop: each poll handles at most this many messages
# and spends at most POLL_BUDGET_S; what is left waits in LCM's queue for the next tick. With LCM's UDP
# provider each subscription's own queue holds at most QUEUE_CAPACITY messages and LCM drops new arrivals
# unseen when it is full, so a real message is lost only if its channel's queue filled since the last poll:
# the capacity holds more than a tick of a 75 000 msg/s flood (75), and a poll may drain that many (a
# refused garbage message costs ~5 us with its dispatch, so ~100 fit the budget). Only the newest message
# per channel is used, the others count as dropped.
MAX_MESSAGES_PER_POLL = 128
POLL_BUDGET_S = 0.0005
QUEUE_CAPACITY = 128
# After a stall (a tick gap longer than an input's deadline) or before the first tick, everything queued is
# from before: `drain` dispatches it all (newest per channel wins, the rest counted in `dropped`), bounded so
# a flood cannot hold the node in it; the node treats what it drained as old (runner, `_receipt_time`).
DRAIN_MAX_MESSAGES = 20_000
DRAIN_BUDGET_S = 0.02
# Sequence numbers (torso_state_t.seq is "+1 per message"): on every input channel a seq that goes back,
# repeats or jumps is counted (`Inbox.seq_anomalies`). The torso state has one producer, the estimator, and
# is used as this tick's q1, so there a repeat or a step back is also refused (never used, as if it had not
# come): a replayed or frozen estimator goes TORSO_STALE within 20 ms. (A lockstep robot's resend of a tick
# the node has answered repeats its torso state too; the node has it already.) An estimator that restarted
# is followed again after SEQ_RESYNC in-order messages of its new sequence. Commands may come from several
# senders (the torso computer, an operator's `spine-cmd --mode estop` starting at seq 0), so they are
# counted, never refused.
SEQ_RESYNC = 3


class Inbox:
    """Newest valid message per channel since the node last looked, plus the rejects.

    `reset_requested` stays True once any command with `reset` arrived until the node takes it, so a
    reset is not lost when a later command supersedes it within one tick."""

    def __init__(self) -> None:
        self.torso: TorsoState | None = None
        self.command: SpineCommand | None = None
        self.heartbeat: Heartbeat | None = None
        self.reset_requested = False
        self.rejects: deque[MessageError] = deque(maxlen=64)
        self.received = 0
        self.dropped: dict[str, int] = dict.fromkeys(_INCOMING, 0)  # superseded before the node looked
        self.rejected: dict[str, int] = dict.fromkeys(_INCOMING, 0)  # refused, per channel
        self._foreign: set[str] = set()  # channels with a refused foreign payload since the last take
        # per channel: {"backwards": n, "repeat": n, "jump": n} (see SEQ_RESYNC)
        self.seq_anomalies: dict[str, dict[str, int]] = {
            ch: {"backwards": 0, "repeat": 0, "jump": 0} for ch in _INCOMING}
        self._last_seq: dict[str, int] = {}
        self._torso_resync: tuple[int, int] | None = None  # (last seq of a new torso sequence, its length)
        self._decode = dict(_INCOMING)

    def decode_commands_for(self, spine: params.SpineParams) -> None:
        """Judge commands' targets by `spine`'s reach and workspace (the model the node runs)."""
        self._decode[channels.SPINE_COMMAND] = (codec.decode_command if spine == params.DEFAULT_SPINE
                                                else codec.CommandDecoder(spine))

    def offer_bytes(self, channel: str, data: bytes) -> None:
        decode = self._decode.get(channel)
        if decode is None:
            return
        self.received += 1
        head = data[:8]
        if head != _FINGERPRINT[channel] and head not in _KNOWN_FINGERPRINTS:
            self.rejected[channel] += 1
            if channel not in self._foreign:  # once per take: a flood must not cost the tick per message
                self._foreign.add(channel)
                self.rejects.append(_FOREIGN[channel])
            return
        try:
            msg = decode(data, channel)
        except MessageError as exc:
            self.rejected[channel] += 1
            self.rejects.append(exc)
            return
        if not self._seq_ok(channel, msg.seq):
            return
        if channel == channels.TORSO_STATE:
            self.dropped[channel] += self.torso is not None
            self.torso = msg
        elif channel == channels.SPINE_COMMAND:
            self.dropped[channel] += self.command is not None
            self.command = msg
            self.reset_requested |= msg.reset
        else:
            self.dropped[channel] += self.heartbeat is not None
            self.heartbeat = msg

    def _seq_ok(self, channel: str, seq: int) -> bool:
        """Count a seq that goes back, repeats or jumps; refuse a torso state's repeat or step back."""
        last = self._last_seq.get(channel)
        if last is None or seq > last:
            if last is not None and seq != last + 1:
                self.seq_anomalies[channel]["jump"] += 1  # messages lost (UDP) or skipped: still used
            self._last_seq[channel] = seq
            if channel == channels.TORSO_STATE:
                self._torso_resync = None
            return True
        counts = self.seq_anomalies[channel]
        counts["repeat" if seq == last else "backwards"] += 1
        if channel != channels.TORSO_STATE:
            self._last_seq[channel] = seq
            return True
        run = self._torso_resync  # a restarted estimator: followed after SEQ_RESYNC in-order messages
        run = (seq, run[1] + 1) if run is not None and seq == run[0] + 1 else (seq, 1)
        self._torso_resync = run
        if run[1] >= SEQ_RESYNC:
            self._last_seq[channel], self._torso_resync = seq, None
            return True
        return False  # not used, like no message: a frozen or replayed estimator goes TORSO_STALE

    def take(self) -> tuple:
        """(torso, command, heartbeat, reset requested, rejects) since the last take; None if none."""
        rejects = self.rejects
        taken = list(rejects) if rejects else []  # a fresh list: the deque is cleared below
        out = (self.torso, self.command, self.heartbeat, self.reset_requested, taken)
        self.torso = self.command = self.heartbeat = None
        self.reset_requested = False
        if rejects:
            rejects.clear()
            self._foreign.clear()
        return out


def _has_torso(inbox: Inbox, seq: int) -> bool:
    t = inbox.torso
    return t is not None and t.seq >= seq


def opening_inputs_in(inbox: Inbox, seq: int) -> bool:
    """Whether a robot's opening tick is complete: a torso state of tick `seq` or later, a heartbeat and a
    command (a robot publishes all three with its first motor feedback)."""
    return _has_torso(inbox, seq) and inbox.heartbeat is not None and inbox.command is not None


class NodeIO:
    """Base: an inbox and two outputs. Subclasses move bytes."""

    def __init__(self) -> None:
        self.inbox = Inbox()
        self.torso_waits = 0  # lockstep ticks whose torso state came after their feedback (await_torso)
        self.instance = 0  # this node's heartbeat instance (set by SpineNode); others heard go to `peers`
        self.peers: dict[int, str] = {}  # other spine nodes heard on SPARC_HEARTBEAT_NODE: instance -> sender

    def offer_node_heartbeat(self, channel: str, data: bytes) -> None:
        """A heartbeat on the node channel: this node's own (LCM loops it back) or another node's."""
        try:
            hb = codec.decode_heartbeat(data, channel)
        except MessageError:
            return
        if hb.instance != self.instance and hb.instance not in self.peers:
            self.peers[hb.instance] = hb.sender
            log.error("another spine node is on this LCM URL: %r, instance %#x (this one: %#x)", hb.sender,
                      hb.instance, self.instance)

    def poll(self) -> None:
        """Move everything that has arrived into the inbox without blocking."""

    def drain(self) -> int:
        """Dispatch everything queued (DRAIN_MAX_MESSAGES, DRAIN_BUDGET_S at most); returns how many.
        In-process delivery is synchronous: nothing is queued."""
        self.poll()
        return 0

    def await_torso(self, seq: int, timeout_s: float) -> bool:
        """Whether the inbox holds a torso state of tick `seq` or later, waiting up to `timeout_s` for it
        where the transport can deliver it late. In-process delivery is synchronous: nothing to wait for."""
        return _has_torso(self.inbox, seq)

    def await_inbox(self, ready: Callable[[Inbox], bool], timeout_s: float) -> bool:
        """Whether `ready(inbox)`, waiting up to `timeout_s` where the transport can deliver late."""
        return ready(self.inbox)

    def publish_state(self, state: SpineState) -> None:
        raise NotImplementedError

    def publish_heartbeat(self, hb: Heartbeat) -> None:
        raise NotImplementedError

    def close(self) -> None:
        pass


class DecodedStates(Sequence):
    """Spine states kept as the bytes the node published (bounded), decoded when read: the receiver's
    decoding is not charged to the node's 1 kHz tick."""

    def __init__(self, keep: int) -> None:
        self._raw: deque[bytes] = deque(maxlen=keep)

    def append_bytes(self, data: bytes) -> None:
        self._raw.append(data)

    def __len__(self) -> int:
        return len(self._raw)

    def __getitem__(self, i):  # type: ignore[override]
        if isinstance(i, slice):
            return [codec.decode_state(b) for b in list(self._raw)[i]]
        return codec.decode_state(self._raw[i])

    def __iter__(self) -> Iterator[SpineState]:
        for b in list(self._raw):
            yield codec.decode_state(b)


class InProcessNodeIO(NodeIO):
    """For a robot in the same process: it calls `deliver`; the node's outputs are kept (bounded) and
    passed to an optional callback. Messages are encoded and decoded like on the wire (spine states are
    decoded when read, or at once for `on_state`)."""

    def __init__(self, keep: int = 100_000, on_state=None) -> None:
        super().__init__()
        self.states = DecodedStates(keep)
        self.heartbeats: deque[Heartbeat] = deque(maxlen=keep)
        self.on_state = on_state

    def deliver(self, channel: str, data: bytes) -> None:
        self.inbox.offer_bytes(channel, data)

    def send_torso(self, t: TorsoState) -> None:
        self.deliver(channels.TORSO_STATE, codec.encode_torso(t))

    def send_command(self, c: SpineCommand) -> None:
        self.deliver(channels.SPINE_COMMAND, codec.encode_command(c))

    def send_heartbeat(self, h: Heartbeat) -> None:
        self.deliver(channels.HEARTBEAT_ROBOT, codec.encode_heartbeat(h))

    def publish_state(self, state: SpineState) -> None:
        data = codec.encode_state(state)
        self.states.append_bytes(data)
        if self.on_state is not None:
            self.on_state(codec.decode_state(data))

    def publish_heartbeat(self, hb: Heartbeat) -> None:
        self.heartbeats.append(hb)


class LcmNodeIO(NodeIO):
    """LCM channels SPARC_TORSO_STATE, SPARC_SPINE_COMMAND, SPARC_HEARTBEAT_ROBOT in;
    SPARC_SPINE_STATE and SPARC_HEARTBEAT_NODE out. Share `lc` with an `LcmMotorBus`."""

    def __init__(self, lc: lcm.LCM) -> None:
        super().__init__()
        self.lc = lc
        self._subs = [lc.subscribe(ch, self.inbox.offer_bytes) for ch in _INCOMING]
        self._subs.append(lc.subscribe(channels.HEARTBEAT_NODE, self.offer_node_heartbeat))
        for sub in self._subs:
            sub.set_queue_capacity(QUEUE_CAPACITY)
        self.publish_errors = 0
        self.handled_last_poll = 0  # messages the last poll dispatched (<= MAX_MESSAGES_PER_POLL)

    def poll(self) -> None:
        """Dispatch what has arrived, bounded in count and time (a flood waits for the next tick)."""
        deadline = time.perf_counter() + POLL_BUDGET_S
        n = 0
        while n < MAX_MESSAGES_PER_POLL and dispatch(self.lc, 0) > 0:
            n += 1
            if time.perf_counter() >= deadline:
                break
        self.handled_last_poll = n

    def listen_for_nodes(self, duration_s: float) -> dict[int, str]:
        """Dispatch for `duration_s` (before this node publishes anything) and return the other nodes heard:
        a node that starts beside a running one refuses to (spine-node exit 2)."""
        deadline = time.perf_counter() + duration_s
        while True:
            left = deadline - time.perf_counter()
            if left <= 0:
                return dict(self.peers)
            if dispatch(self.lc, max(1, round(left * 1e3))) == 0 and time.perf_counter() < deadline:
                return dict(self.peers)  # a signal cut the wait: the caller checks for a stop next

    def drain(self) -> int:
        """Dispatch everything that waited in LCM's queues (see DRAIN_MAX_MESSAGES, DRAIN_BUDGET_S)."""
        deadline = time.perf_counter() + DRAIN_BUDGET_S
        n = 0
        while n < DRAIN_MAX_MESSAGES and dispatch(self.lc, 0) > 0:
            n += 1
            if time.perf_counter() >= deadline:
                break
        self.handled_last_poll = n
        return n

    def await_torso(self, seq: int, timeout_s: float) -> bool:
        """LCM keeps the order of one socket only: with `mpudpm` (a socket per channel) a tick's motor
        feedback can be dispatched before the torso state the robot published ahead of it (seen at load:
        68 of 2500 lockstep ticks ran on the previous tick's q1). Dispatch until it is in, or timeout_s."""
        if _has_torso(self.inbox, seq):
            return True
        self.torso_waits += 1
        return self.await_inbox(lambda inbox: _has_torso(inbox, seq), timeout_s)

    def await_inbox(self, ready: Callable[[Inbox], bool], timeout_s: float) -> bool:
        """Dispatch until `ready(inbox)`, or for `timeout_s`: LCM hands messages over from its receive
        thread, so a message sent before the one just dispatched may not be dispatchable yet."""
        inbox = self.inbox
        if ready(inbox):
            return True
        deadline = time.perf_counter() + timeout_s
        while True:
            dispatch(self.lc, 1)  # ms: one message, or a 1 ms wait
            if ready(inbox):
                return True
            if time.perf_counter() >= deadline:
                return False

    def _publish(self, channel: str, data: bytes) -> None:
        try:
            self.lc.publish(channel, data)
        except OSError as exc:  # the loop never dies on a full socket buffer
            self.publish_errors += 1
            if self.publish_errors in (1, 10, 100, 1000):
                log.warning("LCM publish on %s failed (%d so far): %s", channel, self.publish_errors, exc)

    def publish_state(self, state: SpineState) -> None:
        self._publish(channels.SPINE_STATE, codec.encode_state(state))

    def publish_heartbeat(self, hb: Heartbeat) -> None:
        self._publish(channels.HEARTBEAT_NODE, codec.encode_heartbeat(hb))

    def close(self) -> None:
        for s in self._subs:
            self.lc.unsubscribe(s)
        self._subs = []
