"""LCM motor bus: the node's motors are a (simulated) robot on the other end of an LCM URL.

Channels (docs/robot-side.md): commands go out on SPARC_MOTOR_COMMAND (sparc.motor_command_t, carrying
the seq of the feedback they answer, for lockstep), feedback comes in on SPARC_MOTOR_FEEDBACK
(sparc.motor_feedback_t), decoded and validated by `spine_module.messages`. A rejected feedback message
raises `MotorBusError` from `receive` with the `MessageError` (naming the field) as its cause.

Pass `lc` to share one `lcm.LCM` with the node's other channels. On `udpm` (one socket) messages then
dispatch in the order the robot sent them (torso state before the motor feedback of the same tick); on
`mpudpm` (a socket per channel) they may not, and `run_lockstep` waits for the tick's torso state by seq.

`spin_s` (default 0: block at once): a lockstep wait polls for up to this long before it blocks
(`handle`). A blocked thread lets its CPU go idle, and waking an idle CPU is what a lockstep round trip
pays for on every message: on the 2-vCPU KVM guest the project is measured on, a publish that wakes the
other side costs 40-70 us against ~3 us to a receiver that is awake. Worth it only where the peers have
CPUs of their own (`DEDICATED_CPU_SPIN_S`; docs/performance.md, "LCM lockstep").
"""

from __future__ import annotations

import os
import time

import lcm

from spine_module.buses.base import MotorBus, MotorBusError, MotorCommand, MotorFeedback
from spine_module.messages import channels, codec
from spine_module.messages.dispatch import dispatch

# Each receive() dispatches at most this many LCM messages: with a shared handle, a flood on another channel
# (thousands of queued commands) would otherwise be drained, message by message, inside one receive.
MAX_MESSAGES_PER_RECEIVE = 64
RECEIVE_BUDGET_S = 0.0005  # and spends at most this long dispatching beyond its own timeout
QUEUE_CAPACITY = 16  # per subscription, for LCM's UDP provider (LCM drops what does not fit)
# A poll that covers a simulated robot's step, for lockstep peers on CPUs of their own. Not the default:
# where other work competes for the CPUs a spinning wait holds its CPU against it (measured: 4.3x slower
# than blocking with two busy loops beside the pair, 15 % faster without; docs/performance.md).
DEDICATED_CPU_SPIN_S = 0.001
_clock, _yield_cpu = time.perf_counter, os.sched_yield  # `handle`'s clock and yield (module-level: tests)


def handle(lc: lcm.LCM, timeout_s: float, spin_s: float = 0.0) -> int:
    """Dispatch at most one LCM message, waiting at most `timeout_s`: polling (yielding the CPU to any
    other runnable thread between polls) for the first `spin_s` of it, blocking for the rest. Returns
    LCM's `handle_timeout` result (> 0: a message was dispatched)."""
    if spin_s > 0.0:
        clock, yield_cpu = _clock, _yield_cpu
        end = clock() + min(spin_s, timeout_s)
        while True:
            got = dispatch(lc, 0)
            if got != 0:
                return got
            if clock() >= end:
                break
            yield_cpu()
        timeout_s -= spin_s
        if timeout_s <= 0.0:
            return 0
    return dispatch(lc, max(1, int(timeout_s * 1000)))  # a signal: 0, the caller's loop sees the stop


class LcmMotorBus(MotorBus):
    def __init__(self, url: str = "", lc: lcm.LCM | None = None,
                 command_channel: str = channels.MOTOR_COMMAND,
                 feedback_channel: str = channels.MOTOR_FEEDBACK,
                 max_messages: int = MAX_MESSAGES_PER_RECEIVE, spin_s: float = 0.0) -> None:
        try:
            self.lc = lc if lc is not None else lcm.LCM(url)
        except (OSError, RuntimeError) as exc:
            raise MotorBusError(f"cannot open LCM at {url!r}: {exc}") from exc
        if not spin_s >= 0.0:  # before anything subscribes on a shared handle
            raise ValueError(f"spin_s must be >= 0 s, got {spin_s!r}")
        self.spin_s = spin_s
        self.command_channel, self.feedback_channel = command_channel, feedback_channel
        self._newest: MotorFeedback | None = None
        self._error: codec.MessageError | None = None
        self._last_feedback_seq = -1
        self._last_sent = (-1, 0.0)  # seq and stamp of the last command sent (stop() follows on from it)
        self.dropped = 0  # feedback superseded before the node read it
        self._sub = self.lc.subscribe(feedback_channel, self._on_feedback)
        self._sub.set_queue_capacity(QUEUE_CAPACITY)
        self.max_messages = max_messages
        self.handled_last = 0  # LCM messages the last receive() dispatched (<= max_messages)

    def _on_feedback(self, channel: str, data: bytes) -> None:
        try:
            fb = codec.decode_motor_feedback(data, channel)
        except codec.MessageError as exc:
            self._error = exc
            return
        if self._newest is not None:
            self.dropped += 1
        self._newest = fb

    def send(self, command: MotorCommand) -> None:
        self._last_sent = (command.seq, command.stamp_s)
        try:
            data = codec.encode_motor_command(command, self._last_feedback_seq)
            self.lc.publish(self.command_channel, data)
        except OSError as exc:
            raise MotorBusError(f"LCM publish on {self.command_channel} failed: {exc}") from exc

    def stop(self) -> None:
        """Zero torque, motors stopped, as the next message of the sequence (seq one past the last command
        sent, stamped as it was): a robot that orders commands by seq does not take it for a stale one."""
        seq, stamp_s = self._last_sent
        cmd = MotorCommand.zero(3, enable=False)
        cmd.seq, cmd.stamp_s = seq + 1, stamp_s
        self.send(cmd)

    def receive(self, timeout_s: float | None = 0.0) -> MotorFeedback | None:
        """Newest feedback, dispatching at most `max_messages` LCM messages (of any channel on the shared
        handle) and waiting at most `timeout_s`; None if no feedback got through."""
        t0 = time.monotonic()
        deadline = None if timeout_s is None else t0 + timeout_s
        budget_end = t0 + max(timeout_s or 0.0, RECEIVE_BUDGET_S)
        n = 0
        while self._newest is None and self._error is None and n < self.max_messages:
            now = time.monotonic()
            remaining = 1.0 if deadline is None else deadline - now
            if remaining <= 0:
                if n and now >= budget_end:  # a flood on another channel: the rest waits for next tick
                    break
                if dispatch(self.lc, 0) <= 0:
                    break
                n += 1
                continue
            n += handle(self.lc, remaining, self.spin_s) > 0
        self.handled_last = n
        if self._error is not None:
            err, self._error = self._error, None
            raise MotorBusError(str(err)) from err
        fb, self._newest = self._newest, None
        if fb is not None:
            self._last_feedback_seq = fb.seq
        return fb

    def shutdown(self) -> None:
        if self._sub is not None:
            self.lc.unsubscribe(self._sub)
            self._sub = None
