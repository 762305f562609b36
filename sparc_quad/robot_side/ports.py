"""The robot's end of the spine interface, one `Port` per transport (like python-can's `BusABC` backends).

- `InProcessPort`: the node in this process (in-process bus and node IO), every message through the codec
  as on the wire, so the numbers equal the LCM path's;
- `LcmPort`: the node in another process over LCM;
- `CanEmulatorPort`: the node's motors are emulated CyberGears on a CAN bus (frames carry feedback and
  commands); torso state, heartbeats and the spine command reach the node in process;
- `DirectPort`: no node, a task controller in place (the bench rig).
"""

from __future__ import annotations

import logging
import time

import lcm
import numpy as np

from spine_module.buses.inprocess import InProcessLink
from spine_module.buses.lcm import handle as lcm_handle
from spine_module.messages import (
    Heartbeat,
    MessageError,
    SpineCommand,
    SpineState,
    TorsoState,
    channels,
    codec,
)
from spine_module.messages.motor import MotorCommand, MotorFeedback
from spine_module.node.io import InProcessNodeIO

log = logging.getLogger("sparc_quad.robot_side")


class Port:
    """The robot's end of the interface."""

    def publish_torso(self, t: TorsoState) -> None: ...
    def publish_heartbeat(self, h: Heartbeat) -> None: ...
    def publish_command(self, c: SpineCommand) -> None: ...
    def publish_feedback(self, fb: MotorFeedback) -> None: ...

    def publish_tick(self, torso: TorsoState, heartbeat: Heartbeat | None, command: SpineCommand | None,
                     feedback: MotorFeedback | None) -> float:
        """One tick's messages in the order the node relies on (torso state before the motor feedback);
        None: not sent this tick. Returns `time.perf_counter()` when the feedback went out (the lockstep
        round trip's start)."""
        self.publish_torso(torso)
        if heartbeat is not None:
            self.publish_heartbeat(heartbeat)
        if command is not None:
            self.publish_command(command)
        t = time.perf_counter()
        if feedback is not None:
            self.publish_feedback(feedback)
        return t

    def take_command(self, timeout_s: float, want_seq: int | None) -> MotorCommand | None:
        """Newest motor command; with `want_seq`, wait (up to timeout) for the one answering that feedback."""
        raise NotImplementedError

    def node_heartbeats(self) -> list[Heartbeat]:
        return []

    def close(self) -> None:
        pass


class InProcessPort(Port):
    def __init__(self, link: InProcessLink, node_io: InProcessNodeIO) -> None:
        self.link, self.io = link, node_io

    def publish_torso(self, t: TorsoState) -> None:
        self.io.send_torso(t)

    def publish_heartbeat(self, h: Heartbeat) -> None:
        self.io.send_heartbeat(h)

    def publish_command(self, c: SpineCommand) -> None:
        self.io.send_command(c)

    def publish_feedback(self, fb: MotorFeedback) -> None:
        # through the codec, as on the wire: identical numbers to the LCM path
        data = codec.encode_motor_feedback(fb)
        self.link.robot.publish_feedback(codec.decode_motor_feedback(data))

    def take_command(self, timeout_s: float, want_seq: int | None) -> MotorCommand | None:
        got = self.link.robot.take_command(timeout_s)
        if got is None:
            return None
        cmd, answers = got
        data = codec.encode_motor_command(cmd, answers)
        cmd, answers = codec.decode_motor_command(data)
        if want_seq is not None and answers != want_seq:
            return None
        return cmd

    def node_heartbeats(self) -> list[Heartbeat]:
        hbs = list(self.io.heartbeats)
        self.io.heartbeats.clear()
        return hbs


class CanEmulatorPort(InProcessPort):
    """Motor feedback and commands travel as CAN frames between the node's `CanMotorBus` and the emulated
    CyberGears (which apply the motor law and step the plant); this port carries the rest."""

    def __init__(self, node_io: InProcessNodeIO) -> None:
        super().__init__(InProcessLink(), node_io)

    def publish_feedback(self, fb: MotorFeedback) -> None:
        raise RuntimeError("over CAN the emulated motors send their own feedback frames")

    def take_command(self, timeout_s: float, want_seq: int | None) -> MotorCommand | None:
        return None  # the emulated motors took it off the bus


class LcmPort(Port):
    """Robot side over LCM. Spine states from the node are kept in `states` when `keep_states`: as the
    bytes that arrived, decoded when `states` is read, so the robot's 1 kHz loop does not pay for them.

    `rejected` counts the node's messages that failed validation: motor commands and heartbeats when they
    arrive, spine states when `states` decodes them (read `states`, or `drain_states`, first for a full
    count). Reading `rejected` changes nothing."""

    def __init__(self, url: str = "", lc: lcm.LCM | None = None, keep_states: bool = True,
                 spin_s: float = 0.0) -> None:
        """`spin_s`: a lockstep wait for the node's answer polls this long before it blocks
        (`spine_module.buses.lcm.handle`)."""
        if not spin_s >= 0.0:
            raise ValueError(f"spin_s must be >= 0 s, got {spin_s!r}")
        self.spin_s = spin_s
        self.lc = lc if lc is not None else lcm.LCM(url)
        self._cmd: tuple[MotorCommand, int] | None = None
        self._hbs: list[Heartbeat] = []
        self._states: list[SpineState] = []
        self._raw_states: list[bytes] = []
        self.keep_states = keep_states
        self.rejected = 0
        self._subs = [self.lc.subscribe(channels.MOTOR_COMMAND, self._on_command),
                      self.lc.subscribe(channels.HEARTBEAT_NODE, self._on_heartbeat)]
        if keep_states:
            self._subs.append(self.lc.subscribe(channels.SPINE_STATE, self._on_state))

    @property
    def states(self) -> list[SpineState]:
        """The node's spine states received so far. Those that arrived since the last read are decoded
        now; a malformed one is logged and counted in `rejected`."""
        raw, self._raw_states = self._raw_states, []
        for data in raw:
            try:
                self._states.append(codec.decode_state(data, channels.SPINE_STATE))
            except (MessageError, ValueError) as exc:
                self.rejected += 1
                log.warning("rejected %s", exc)
        return self._states

    def _on_command(self, channel: str, data: bytes) -> None:
        try:
            self._cmd = codec.decode_motor_command(data, channel)
        except MessageError as exc:
            self.rejected += 1
            log.warning("rejected %s", exc)

    def _on_heartbeat(self, channel: str, data: bytes) -> None:
        try:
            self._hbs.append(codec.decode_heartbeat(data, channel))
        except MessageError as exc:
            self.rejected += 1
            log.warning("rejected %s", exc)

    def _on_state(self, channel: str, data: bytes) -> None:
        self._raw_states.append(data)

    def publish_torso(self, t: TorsoState) -> None:
        self.lc.publish(channels.TORSO_STATE, codec.encode_torso(t))

    def publish_heartbeat(self, h: Heartbeat) -> None:
        self.lc.publish(channels.HEARTBEAT_ROBOT, codec.encode_heartbeat(h))

    def publish_command(self, c: SpineCommand) -> None:
        self.lc.publish(channels.SPINE_COMMAND, codec.encode_command(c))

    def publish_feedback(self, fb: MotorFeedback) -> None:
        self.lc.publish(channels.MOTOR_FEEDBACK, codec.encode_motor_feedback(fb))

    def publish_tick(self, torso: TorsoState, heartbeat: Heartbeat | None, command: SpineCommand | None,
                     feedback: MotorFeedback | None) -> float:
        """Everything encoded first, then published back to back: the node's receiving thread, woken by
        the first datagram, is still awake for the rest, which then cost no further wake-up (~40 us each
        on the measuring VM, docs/performance.md "LCM lockstep")."""
        out = [(channels.TORSO_STATE, codec.encode_torso(torso))]
        if heartbeat is not None:
            out.append((channels.HEARTBEAT_ROBOT, codec.encode_heartbeat(heartbeat)))
        if command is not None:
            out.append((channels.SPINE_COMMAND, codec.encode_command(command)))
        fb = codec.encode_motor_feedback(feedback) if feedback is not None else None
        publish = self.lc.publish
        for channel, data in out:
            publish(channel, data)
        t = time.perf_counter()
        if fb is not None:
            publish(channels.MOTOR_FEEDBACK, fb)
        return t

    def take_command(self, timeout_s: float, want_seq: int | None) -> MotorCommand | None:
        deadline = time.monotonic() + timeout_s
        while True:
            if self._cmd is not None and (want_seq is None or self._cmd[1] == want_seq):
                cmd, self._cmd = self._cmd[0], None
                return cmd
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                while self.lc.handle_timeout(0) > 0:
                    pass
                if self._cmd is not None and (want_seq is None or self._cmd[1] == want_seq):
                    continue
                return None
            lcm_handle(self.lc, remaining, self.spin_s)

    def node_heartbeats(self) -> list[Heartbeat]:
        while self.lc.handle_timeout(0) > 0:
            pass
        hbs, self._hbs = self._hbs, []
        return hbs

    def drain_states(self, duration_s: float = 0.3) -> list[SpineState]:
        """Collect the node's spine states still in flight for `duration_s` (wall), then return all."""
        t_end = time.monotonic() + duration_s
        while time.monotonic() < t_end:
            self.lc.handle_timeout(20)
        return list(self.states)

    def close(self) -> None:
        for s in self._subs:
            self.lc.unsubscribe(s)
        self._subs = []


class DirectPort(Port):
    """No node and no messages: a task controller (`spine_module.control`) computes the torques from each
    tick's feedback, in place, as the bench rig does. Keeps the controller's task pose estimate `x_meas`
    and torque `tau_cmd` per tick."""

    def __init__(self, controller) -> None:
        self.controller = controller
        self._q1 = (0.0, 0.0)
        self._cmd: tuple[MotorCommand, int] | None = None
        self.x_meas: list[np.ndarray] = []
        self.tau_cmd: list[np.ndarray] = []

    def publish_torso(self, t: TorsoState) -> None:
        self._q1 = (t.q1, t.dq1)

    def publish_feedback(self, fb: MotorFeedback) -> None:
        q1, dq1 = self._q1
        out = self.controller.step(np.concatenate(([q1], fb.q)), np.concatenate(([dq1], fb.dq)))
        self.x_meas.append(out.x.copy())
        self.tau_cmd.append(out.tau.copy())
        self._cmd = (MotorCommand(tau_ff=out.tau.copy()), fb.seq)

    def take_command(self, timeout_s: float, want_seq: int | None) -> MotorCommand | None:
        if self._cmd is None or (want_seq is not None and self._cmd[1] != want_seq):
            return None
        cmd, self._cmd = self._cmd[0], None
        return cmd
