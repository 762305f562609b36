"""`CanMotorBus`: the spine's motors as CyberGear actuators on one python-can bus.

One `can.Bus` carries every motor; a `can.Notifier` thread decodes the motors' frames into per-joint
state; `send` encodes one frame per motor and hands it to the bus with a zero timeout, so it never waits
in the control loop (a full transmit queue is a send error, which the node turns into its safe state).

Torque control, chosen in the configuration:
- "operation": type-1 frames carry tau_ff, q_des, dq_des, kp, kd (kp = kd = 0 for pure torque control);
  the motor's own loop closes the PD part. Each frame is answered by a type-2 feedback frame.
- "current": run_mode 3; each cycle writes iq_ref = tau / kt (type 18), the PD part is closed here from the
  newest feedback. Each write is answered by a type-2 feedback frame.

Safety: the motor's own watchdog (firmware CAN_TIMEOUT, off by default) is written at start-up from the
config's `can_timeout_s` and read back; `start()` refuses to run when it cannot be set. On top, `stop()`
sends type-4 frames on exit, on exceptions (`with` block), and on SIGINT/SIGTERM (`install_stop_handlers`).
Transport faults, motors silent past `silent_timeout_s`, malformed frames from a configured motor, fault
frames (type 21) and fault bits in feedback all raise `MotorBusError`, the node's cue for its safe state.
"""

from __future__ import annotations

import atexit
import contextlib
import itertools
import logging
import math
import signal
import threading
import time
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import can
import numpy as np

from spine_module.buses.base import MotorBus, MotorBusError, MotorCommand, MotorFeedback, MotorSetupError
from spine_module.buses.cybergear import protocol as P
from spine_module.buses.cybergear.busload import bus_load
from spine_module.buses.cybergear.config import CyberGearConfig, load_config
from spine_module.buses.cybergear.plausibility import DEFAULT_LIMITS, PlausibilityLimits, Reading, implausible

log = logging.getLogger(__name__)

FAULT_FRAME_FLAG = 1 << 8  # set in MotorFeedback.fault when a type-21 frame arrived from that motor
CAN_ERR_BUSOFF = 0x40  # SocketCAN error-frame class bit for bus-off
# From enable (end of `start()`) to the node's first `send`, zero-torque frames keep the motors inside their
# CAN timeout (HOLD_PERIOD_MAX_S apart, or a fifth of the timeout if shorter), for at most HOLD_MAX_S: a
# node that has not started controlling by then gets its motors stopped (its first send enables them again)
HOLD_PERIOD_MAX_S = 0.01
HOLD_MAX_S = 2.0
# every motor silent (cable, bus or host gone) is a lost bus after this long, or two silent_timeout_s if
# longer; one motor silent while the others answer is lost after silent_timeout_s (CanMotorBus._silent).
# The motors' own CAN timeout (50 ms shipped) stops them meanwhile
SILENT_ALL_MIN_S = 0.5


@dataclass
class _JointState:
    q: float = 0.0
    dq: float = 0.0
    tau: float = 0.0
    temperature_c: float = 0.0
    mode: int = 0
    fault_bits: int = 0
    fault_value: int = 0
    warning_value: int = 0
    stamp_s: float = 0.0
    frames: int = 0
    fresh: bool = False
    uid: bytes | None = None  # MCU uid of the first get-id reply since start()
    uids: set[bytes] = field(default_factory=set)  # every uid that answered as this id since start()
    reading: Reading | None = None  # last plausible feedback (plausibility.py)
    implausible: bool = False  # a plausibility fault is latched for this motor (one message, not one a frame)
    unanswered_since: float | None = None  # monotonic time of the oldest command without a reply
    unanswered_wall: float | None = None  # the same on the frames' clock (time.time(), Message.timestamp)
    run_seen: bool = False  # reported RUN since the last enable
    params: dict[int, tuple[bool, float | int]] = field(default_factory=dict)  # index -> (ok, value) read


def open_bus(interface: str, channel: str, bitrate: int | None = None, **kwargs) -> can.BusABC:
    """A python-can bus with the usual three options; `bitrate` is ignored by virtual interfaces."""
    kw = dict(kwargs)
    if bitrate is not None and interface not in ("virtual", "udp_multicast"):
        kw["bitrate"] = bitrate
    return can.Bus(interface=interface, channel=channel, **kw)


def _per_joint(a, n: int) -> list[float]:
    """`a` (one value, or one per joint) as `n` Python floats; ValueError if it has another length."""
    v = np.asarray(a, dtype=float)
    return (v if v.shape == (n,) else np.broadcast_to(v, (n,))).tolist()


class CanMotorBus(MotorBus):
    """MotorBus backend for Xiaomi CyberGear motors on one CAN bus (see module docstring)."""

    def __init__(self, config: CyberGearConfig | str | Path | None = None, bus: can.BusABC | None = None, *,
                 interface: str | None = None, channel: str | None = None, bitrate: int | None = None,
                 log_path: str | Path | None = None, bus_options: dict | None = None,
                 fault_raises: bool = True,
                 clock: Callable[[], float] = time.monotonic,
                 stamp_clock: Callable[[], float] | None = None, hold_max_s: float = HOLD_MAX_S,
                 plausibility: PlausibilityLimits = DEFAULT_LIMITS) -> None:
        if config is None or isinstance(config, (str, Path)):
            config = load_config(config)
        self.config = config
        self.joint_names = tuple(j.name for j in config.joints)
        self._ids = {j.can_id: i for i, j in enumerate(config.joints)}
        self._ranges = config.ranges
        self._clock = clock  # timeouts
        self._stamp_clock = stamp_clock or clock  # MotorFeedback.stamp_s (a simulation may supply its time)
        # the plausibility checks' time between two frames of a motor: the frames' own receive stamps (the
        # adapter's or the kernel's), which a host that processes bunched frames late does not squeeze;
        # a simulation's stamp clock when one is given (its motors move in simulated time)
        self._frame_time_from_msg = stamp_clock is None
        self.fault_raises = fault_raises
        self.plausibility = plausibility
        self._own_bus = bus is None
        if bus is None:
            if interface is None or channel is None:
                raise ValueError("give a python-can bus, or interface and channel")
            bus = open_bus(interface, channel, bitrate or config.bitrate, **(bus_options or {}))
        self.bus = bus
        # re-entrant: a signal handler calling stop() may interrupt the main thread inside receive()
        self._lock = threading.RLock()
        self._cond = threading.Condition(self._lock)
        self._stop_lock = threading.Lock()  # one stop sequence at a time; shutdown waits for it
        self._state = [_JointState() for _ in config.joints]
        self._latest_rx_wall = 0.0  # Message.timestamp of the newest frame from a configured motor
        # latched faults: raised by every receive() (so the node's feedback goes stale and it drops to its
        # safe state) and by send() with enable=True, until start() clears them with the motors' faults
        self._errors: list[str] = []
        self._enabled = False
        self._started = False
        self._closed = False
        self._seq = 0
        self.tx_frames = 0
        self.rx_frames = 0
        self.stop_frames_sent = 0
        self.send_errors = 0
        self.ignored: Counter[str] = Counter()  # frames not for us: reason -> count
        self.last_error: str | None = None
        self.can_timeout_confirmed: dict[str, int] = {}  # joint -> CAN_TIMEOUT read back at start-up
        # zero-torque frames from start() until the first send, for at most hold_max_s (see HOLD_MAX_S); 0:
        # none, for rigs whose motors' CAN timeout runs on simulated time (a lockstep emulator)
        self.hold_max_s = hold_max_s
        self._holding = False
        self._hold_wake = threading.Event()
        self._hold_gen = 0  # a hold thread left from an earlier start() sees a newer number and ends
        self.hold_frames_sent = 0
        self._logger = _SessionLog(log_path) if log_path else None
        self._notifier = can.Notifier(self.bus, [_Listener(self)], timeout=0.05)
        self.load = bus_load(len(config.joints), config.rate_hz, config.bitrate)
        self._t_created = time.monotonic()

    # --- receive path (notifier thread) ----------------------------------------------------------------
    def _on_message(self, msg: can.Message) -> None:
        if msg.is_error_frame:
            with self._cond:
                if msg.arbitration_id & CAN_ERR_BUSOFF:
                    self._fault("bus-off reported by the CAN controller")
                else:
                    self.ignored["error frame"] += 1
            return
        comm, data2, target = P.split_id(msg.arbitration_id)
        try:
            frame = P.decode_from_motor(msg, self.config.host_id, set(self._ids), self._ranges)
        except P.FrameError as e:
            with self._cond:
                claims_ours = (msg.is_extended_id and comm in (P.CommType.FEEDBACK, P.CommType.FAULT)
                               and (data2 & 0xFF) in self._ids and target == self.config.host_id)
                if claims_ours:
                    j = self.config.joints[self._ids[data2 & 0xFF]]
                    self._fault(f"malformed frame from motor {j.name} (CAN id {j.can_id}): {e.reason}")
                else:
                    self.ignored[e.reason.split(",")[0][:60]] += 1
            return
        with self._cond:
            self.rx_frames += 1
            if frame.motor_id in self._ids:  # the newest frame from our motors, on the frames' own clock
                self._latest_rx_wall = max(self._latest_rx_wall, msg.timestamp or time.time())
            i = self._ids.get(frame.motor_id)
            if i is None:  # a DeviceId reply from an unconfigured motor
                self.ignored["unconfigured motor"] += 1
                return
            s, j = self._state[i], self.config.joints[i]
            if isinstance(frame, P.Feedback):
                q, dq, tau, stamp = (j.q_from_motor(frame.position), j.dq_from_motor(frame.velocity),
                                     j.tau_from_motor(frame.torque), self._stamp_clock())
                t_frame = msg.timestamp if self._frame_time_from_msg and msg.timestamp else stamp
                if self._started and self.fault_raises:
                    why = implausible(j.name, j.gear_ratio, self.config.limit_torque_nm, s.reading, q, dq,
                                      tau, t_frame, frame.velocity, self.plausibility)
                    if why is not None:  # never handed to the node: the last plausible reading stays
                        if not s.implausible:
                            s.implausible = True
                            self._fault(f"implausible feedback from motor {j.name} (CAN id {j.can_id}): "
                                        f"{why}")
                        self._cond.notify_all()
                        return
                s.q, s.dq, s.tau = q, dq, tau
                s.reading = Reading(q, dq, t_frame)
                s.temperature_c, s.mode, s.fault_bits = frame.temperature_c, frame.mode, frame.fault_bits
                s.stamp_s, s.fresh, s.unanswered_since, s.unanswered_wall = stamp, True, None, None
                s.frames += 1
                if frame.fault_bits and self.fault_raises and self._started:
                    self._fault(f"motor {j.name} (CAN id {j.can_id}) reports "
                                f"{', '.join(P.describe_feedback_faults(frame.fault_bits))}")
                if frame.mode == P.MotorMode.RUN:
                    s.run_seen = True
                elif self._enabled and self._started and s.run_seen:
                    mode = P.MotorMode(frame.mode).name if frame.mode <= 2 else str(frame.mode)
                    self._fault(f"motor {j.name} (CAN id {j.can_id}) left run mode (mode {mode})")
            elif isinstance(frame, P.FaultFrame):
                s.fault_value, s.warning_value = frame.fault_value, frame.warning_value
                if frame.fault_value and self.fault_raises:
                    self._fault(f"fault frame from motor {j.name} (CAN id {j.can_id}): "
                                f"{', '.join(frame.descriptions) or hex(frame.fault_value)}")
                elif frame.warning_value:
                    log.warning("motor %s warning %#x", j.name, frame.warning_value)
            elif isinstance(frame, P.DeviceId):
                if s.uid is None:
                    s.uid = frame.uid
                elif frame.uid != s.uid and frame.uid not in s.uids and self._started:
                    self._fault(f"motor {j.name} (CAN id {j.can_id}): a get-id reply from MCU uid "
                                f"{frame.uid.hex()}, not the handshake's {s.uid.hex()}: two motors answer "
                                "as one id")
                s.uids.add(frame.uid)
            elif isinstance(frame, P.ParamReadReply):
                s.params[frame.index] = (frame.ok, frame.value)
            self._cond.notify_all()

    def _on_error(self, exc: Exception) -> None:
        with self._cond:
            self._fault(f"CAN receive failed: {exc!r}")
            self._cond.notify_all()

    def _fault(self, reason: str) -> None:  # caller holds the lock
        if reason not in self._errors:
            self._errors.append(reason)
            log.error("%s", reason)

    def _raise_pending(self) -> None:  # caller holds the lock
        if self._errors:
            self.last_error = "; ".join(self._errors)
            raise MotorBusError(self.last_error)

    @property
    def latched_faults(self) -> list[str]:
        with self._cond:
            return list(self._errors)

    # --- send path -----------------------------------------------------------------------------------
    def _send(self, msg: can.Message) -> None:
        if self._closed:
            raise MotorBusError("CAN bus already shut down")
        state = getattr(self.bus, "state", can.BusState.ACTIVE)
        if state == can.BusState.ERROR:
            raise MotorBusError("CAN bus is in its error (bus-off) state")
        try:
            self.bus.send(msg, timeout=0.0)
        except (can.CanError, OSError) as e:
            self.send_errors += 1
            raise MotorBusError(f"CAN send failed: {e}") from e
        self.tx_frames += 1
        if self._logger is not None:
            sent = can.Message(timestamp=time.time(), arbitration_id=msg.arbitration_id, data=msg.data,
                               is_extended_id=True, is_rx=False, channel=msg.channel)
            self._logger.on_message_received(sent)

    def _expect_reply(self, i: int, now: float) -> None:
        s = self._state[i]
        if s.unanswered_since is None:
            s.unanswered_since = now
            s.unanswered_wall = time.time()

    def send(self, command: MotorCommand) -> None:
        """Encode one frame per motor and queue it without waiting. Raises MotorBusError on faults."""
        if self._holding:  # the node's first command: from here its own frames feed the motors
            self._end_hold()
        now = self._clock()
        n = len(self.config.joints)
        if not command.enable:
            self._send_stops()
            return
        with self._cond:
            latched = bool(self._errors)
        if latched:  # never drive motors while a fault is latched
            self._send_stops()
            with self._cond:
                self._raise_pending()
        try:  # plain floats: the per-joint scaling and encoding below is scalar arithmetic
            columns = [_per_joint(a, n) for a in
                       (command.tau_ff, command.q_des, command.dq_des, command.kp, command.kd)]
        except ValueError as e:
            raise MotorBusError(f"command does not have {n} joints: {e}") from e
        if not all(map(math.isfinite, itertools.chain.from_iterable(columns))):
            self._send_stops()
            raise MotorBusError("non-finite motor command; motors stopped")
        tau, q_des, dq_des, kp, kd = columns
        if not self._enabled:
            self._send_enables()
        host = self.config.host_id
        for i, j in enumerate(self.config.joints):
            if self.config.torque_mode == "operation":
                msg = P.encode_operation_control(
                    j.can_id, j.tau_to_motor(tau[i]), j.q_to_motor(q_des[i]), j.dq_to_motor(dq_des[i]),
                    j.kp_to_motor(kp[i]), j.kd_to_motor(kd[i]), self._ranges)
            else:
                s = self._state[i]
                t = tau[i] + kp[i] * (q_des[i] - s.q) + kd[i] * (dq_des[i] - s.dq)
                iq = j.tau_to_motor(t) / self.config.kt_nm_per_a
                msg = P.encode_param_write(j.can_id, "iq_ref", iq, host)
            with self._cond:  # before sending: the reply may arrive before _send returns
                self._expect_reply(i, now)
            self._send(msg)

    def _send_enables(self) -> None:
        with self._cond:
            for s in self._state:
                s.run_seen = False
            self._enabled = True  # before the frames: a motor that then drops out of RUN is a fault
        for j in self.config.joints:
            self._send(P.encode_enable(j.can_id, self.config.host_id))

    def _send_stops(self, clear_fault: bool = False) -> None:
        """Type 4 to every motor; tries every motor even if one send fails, then raises the first error.

        `_enabled` is cleared (under the lock) BEFORE the first frame goes out: a motor answers a stop
        within about 250 us, often before `send` returns, and its RESET reply to our own stop must not
        read as "left run mode"."""
        first: Exception | None = None
        now = self._clock()
        with self._cond:
            self._enabled = False
            self._holding = False
            for s in self._state:
                s.run_seen = False
        for i, j in enumerate(self.config.joints):
            try:
                with self._cond:
                    self._expect_reply(i, now)
                self._send(P.encode_stop(j.can_id, self.config.host_id, clear_fault))
                self.stop_frames_sent += 1
            except Exception as e:
                first = first or e
        if first is not None:
            raise first

    def stop(self) -> None:
        """Stop every motor (type 4). Safe to call more than once, from any thread, after faults; never
        raises."""
        with self._stop_lock:
            if self._closed:
                return
            try:
                self._send_stops()
            except Exception as e:
                log.error("could not send every stop frame: %s", e)

    # --- receive -------------------------------------------------------------------------------------
    def _silent(self, now: float) -> list[str]:
        """Motors lost: a command unanswered while another motor's frame came `silent_timeout_s` later (on
        the frames' clock: a host that processes its queue late sees the replies in order, so its own stall
        is no motor's silence), or unanswered for `silent_all_s` whatever else came (the bus or every
        motor gone)."""
        out = []
        timeout, latest = self.config.silent_timeout_s, self._latest_rx_wall
        silent_all_s = max(SILENT_ALL_MIN_S, 2.0 * timeout)
        for s, j in zip(self._state, self.config.joints, strict=True):
            if s.unanswered_since is None:
                continue
            others_later = s.unanswered_wall is not None and latest - s.unanswered_wall > timeout
            if others_later or now - s.unanswered_since > silent_all_s:
                out.append(f"{j.name} (CAN id {j.can_id})")
        return out

    def receive(self, timeout_s: float | None = 0.0) -> MotorFeedback | None:
        """Newest feedback once every motor has answered since the last one returned; None on timeout."""
        deadline = None if timeout_s is None else self._clock() + timeout_s
        with self._cond:
            while True:
                self._raise_pending()
                if all(s.fresh for s in self._state):
                    return self._snapshot()
                now = self._clock()
                if self._started:
                    silent = self._silent(now)
                    if silent:  # latched: a motor that answers again is not driven until start()
                        self._fault(f"motor(s) stopped answering: {', '.join(silent)}")
                        self._raise_pending()
                if deadline is not None and now >= deadline:
                    return None
                wait = 0.01 if deadline is None else min(0.01, deadline - now)
                self._cond.wait(wait)

    def _snapshot(self) -> MotorFeedback:  # caller holds the lock
        st = self._state
        for s in st:
            s.fresh = False
        self._seq += 1
        fault = np.array([s.fault_bits | (FAULT_FRAME_FLAG if s.fault_value else 0) for s in st],
                         dtype=np.int32)
        return MotorFeedback(q=np.array([s.q for s in st]), dq=np.array([s.dq for s in st]),
                             tau=np.array([s.tau for s in st]),
                             temperature_c=np.array([s.temperature_c for s in st]),
                             mode=np.array([s.mode for s in st], dtype=np.int32), fault=fault,
                             stamp_s=max(s.stamp_s for s in st), seq=self._seq)

    # --- start-up / shutdown -------------------------------------------------------------------------
    def _wait_all(self, ok: Callable[[_JointState], bool], timeout_s: float) -> list[str]:
        deadline = self._clock() + timeout_s
        with self._cond:
            while True:
                missing = [f"{j.name} (CAN id {j.can_id})"
                           for s, j in zip(self._state, self.config.joints, strict=True) if not ok(s)]
                now = self._clock()
                if not missing or now >= deadline:
                    return missing
                self._cond.wait(min(0.01, deadline - now))

    def start(self, timeout_s: float | None = None) -> None:
        """Handshake: every motor answers get-id, clears faults, takes its run mode and enables.

        Raises MotorBusError naming the motors that did not answer (after sending them stop frames).
        """
        timeout_s = self.config.handshake_timeout_s if timeout_s is None else timeout_s
        host, cfg = self.config.host_id, self.config
        try:
            with self._cond:
                self._started = False
                self._errors.clear()
                for s in self._state:
                    s.uid, s.fault_value, s.warning_value = None, 0, 0
                    s.uids, s.reading, s.implausible = set(), None, False
            for j in cfg.joints:
                self._send(P.encode_get_id(j.can_id, host))
            missing = self._wait_all(lambda s: s.uid is not None, timeout_s)
            if missing:
                raise MotorBusError(f"no answer within {timeout_s:g} s from motor(s) {', '.join(missing)}")
            with self._cond:
                for s in self._state:
                    s.frames = 0
            run_mode = P.RunMode.OPERATION if cfg.torque_mode == "operation" else P.RunMode.CURRENT
            with self._cond:
                self._enabled = False
            for j in cfg.joints:  # the firmware switches mode only when stopped
                self._send(P.encode_stop(j.can_id, host, clear_fault=True))
                self._send(P.encode_param_write(j.can_id, "run_mode", int(run_mode), host))
                self._send(P.encode_param_write(j.can_id, "limit_torque", cfg.limit_torque_nm, host))
                if run_mode == P.RunMode.CURRENT:
                    self._send(P.encode_param_write(j.can_id, "iq_ref", 0.0, host))
            self._set_can_timeout(timeout_s)
            self._send_enables()
            missing = self._wait_all(
                lambda s: s.frames >= 1 and s.mode == P.MotorMode.RUN and not s.fault_bits, timeout_s)
            if missing:
                with self._cond:
                    why = []
                    for s, j in zip(self._state, self.config.joints, strict=True):
                        faults = (P.describe_feedback_faults(s.fault_bits)
                                  + P.describe_fault_value(s.fault_value))
                        if s.frames:
                            why.append(f"{j.name}: mode {s.mode}, faults {', '.join(faults) or 'none'}")
                raise MotorBusError(f"motor(s) {', '.join(missing)} did not enable within {timeout_s:g} s"
                                    + (f" ({'; '.join(why)})" if why else ""))
            with self._cond:
                self._refuse_doubles_and_strays()
                self._errors.clear()
                for s in self._state:
                    s.unanswered_since = s.unanswered_wall = None
                self._started = True
            self._start_hold()
        except BaseException:
            self.stop()
            raise

    def _refuse_doubles_and_strays(self) -> None:  # caller holds the lock
        """End of the handshake: two MCU uids answering as one id (MotorSetupError: fix the wiring, exit
        2), or a motor whose first feedback is already implausible (outside its joint's range)."""
        doubled = [f"CAN id {j.can_id} ({j.name}): MCU uids {', '.join(sorted(u.hex() for u in s.uids))}"
                   for s, j in zip(self._state, self.config.joints, strict=True) if len(s.uids) > 1]
        if doubled:
            raise MotorSetupError(f"two motors answer as one id: {'; '.join(doubled)}. Give each motor its "
                                  "own id (sparc-quad motors set-id) before running")
        bad = []
        for s, j in zip(self._state, self.config.joints, strict=True):
            why = implausible(j.name, j.gear_ratio, self.config.limit_torque_nm, None, s.q, s.dq, s.tau,
                              s.stamp_s, j.dq_to_motor(s.dq), self.plausibility)
            if why is not None:
                bad.append(f"{j.name} (CAN id {j.can_id}): {why}")
        if bad:
            raise MotorBusError(f"implausible feedback at start-up: {'; '.join(bad)}")

    # --- from enable to the first command ------------------------------------------------------------
    def _zero_frames(self) -> list[can.Message]:
        host = self.config.host_id
        if self.config.torque_mode == "operation":
            return [P.encode_operation_control(j.can_id, 0.0, 0.0, 0.0, 0.0, 0.0, self._ranges)
                    for j in self.config.joints]
        return [P.encode_param_write(j.can_id, "iq_ref", 0.0, host) for j in self.config.joints]

    def _start_hold(self) -> None:
        if self.hold_max_s <= 0:
            return
        with self._cond:
            self._holding = True
            self._hold_gen += 1
            gen = self._hold_gen
        self._hold_wake.clear()
        threading.Thread(target=self._hold, args=(gen,), name="cybergear-hold", daemon=True).start()

    def _end_hold(self) -> None:
        with self._cond:  # after this no hold frame goes out: the thread sends only under the lock
            self._holding = False
        self._hold_wake.set()

    def _hold(self, gen: int) -> None:
        """Zero-torque frames (operation: type 1 with kp = kd = 0; current: iq_ref = 0) until the node's
        first send, a stop, or HOLD_MAX_S: the motors were enabled by start() and their CAN timeout counts
        from then, while the node may need longer than that to reach its first tick."""
        timeout_s = self.config.can_timeout_s
        period = min(HOLD_PERIOD_MAX_S, timeout_s / 5) if timeout_s > 0 else HOLD_PERIOD_MAX_S
        frames = self._zero_frames()
        deadline = self._clock() + self.hold_max_s
        while not self._hold_wake.wait(period):
            with self._cond:
                if not self._holding or not self._enabled or self._closed or gen != self._hold_gen:
                    return
                now = self._clock()
                if now < deadline:
                    try:
                        for i, msg in enumerate(frames):
                            self._expect_reply(i, now)
                            self._send(msg)
                            self.hold_frames_sent += 1
                    except MotorBusError as e:
                        self._fault(f"zero-torque frame before the first command: {e}")
                    continue
                self._holding = False
            log.warning("no command within %g s of enabling the motors: motors stopped", self.hold_max_s)
            self.stop()
            return

    def _set_can_timeout(self, timeout_s: float) -> None:
        """Write the firmware's CAN_TIMEOUT (see protocol.CAN_TIMEOUT_INDEX for the source and its doubts)
        to every motor and read it back; MotorBusError naming the motors where the read-back is missing
        or differs. `can_timeout_off = true` (with `can_timeout_s = 0`) in the config skips this and warns:
        nothing then stops the motors if this process dies without running its stop handlers, except the
        separate watchdog. The config refuses any other way to 0 ticks."""
        cfg, host, idx = self.config, self.config.host_id, P.CAN_TIMEOUT_INDEX
        if cfg.can_timeout_off:
            log.warning("MOTOR WATCHDOG OFF (can_timeout_off = true): the motors' own CAN timeout is not "
                        "set; if this process is killed the motors keep their last command unless "
                        "`sparc-quad motors watchdog` runs")
            return
        ticks = cfg.can_timeout_ticks
        with self._cond:
            for s in self._state:
                s.params.pop(idx, None)
        for j in cfg.joints:
            self._send(P.encode_param_write(j.can_id, idx, ticks, host))
            self._send(P.encode_param_read(j.can_id, idx, host))
        self._wait_all(lambda s: idx in s.params, timeout_s)
        bad = []
        with self._cond:
            for s, j in zip(self._state, cfg.joints, strict=True):
                got = s.params.get(idx)
                if got is None:
                    bad.append(f"{j.name} (CAN id {j.can_id}): no read-back")
                elif not got[0] or got[1] != ticks:
                    bad.append(f"{j.name} (CAN id {j.can_id}): read back {got[1]!r}"
                               + ("" if got[0] else " (read failed)"))
        if bad:
            raise MotorBusError(f"could not set the motors' CAN timeout (CAN_TIMEOUT 0x{idx:04X} = {ticks}, "
                                f"{cfg.can_timeout_s:g} s): {'; '.join(bad)}. Refusing to run: set "
                                f"can_timeout_s = 0 and can_timeout_off = true in the motor config only with "
                                f"the watchdog running")
        self.can_timeout_confirmed = {j.name: ticks for j in cfg.joints}

    def shutdown(self) -> None:
        """Stop the motors (the CyberGear has no watchdog: never leave them running), then release the bus."""
        self.stop()
        with self._stop_lock:
            if self._closed:
                return
            self._closed = True
        self._notifier.stop()
        if self._logger is not None:
            self._logger.stop()
        if self._own_bus:
            self.bus.shutdown()

    def __exit__(self, *exc: object) -> None:
        try:
            self.stop()
        finally:
            self.shutdown()

    # --- introspection ----------------------------------------------------------------------------------
    def stats(self) -> dict[str, float | int]:
        """Frames counted since construction, their rates, and the bus-load model at the configured rate."""
        dt = max(time.monotonic() - self._t_created, 1e-9)
        return {"tx_frames": self.tx_frames, "rx_frames": self.rx_frames, "tx_per_s": self.tx_frames / dt,
                "rx_per_s": self.rx_frames / dt, "send_errors": self.send_errors,
                "stop_frames_sent": self.stop_frames_sent, "hold_frames_sent": self.hold_frames_sent,
                "ignored": sum(self.ignored.values()),
                "model_utilisation_worst": self.load.utilisation_worst}

    def fault_report(self) -> dict[str, dict[str, object]]:
        with self._cond:
            return {j.name: {"can_id": j.can_id, "mode": s.mode,
                             "feedback_faults": P.describe_feedback_faults(s.fault_bits),
                             "fault_frame": P.describe_fault_value(s.fault_value),
                             "warning_value": s.warning_value}
                    for s, j in zip(self._state, self.config.joints, strict=True)}


class _Listener(can.Listener):
    def __init__(self, owner: CanMotorBus) -> None:
        self.owner = owner

    def on_message_received(self, msg: can.Message) -> None:
        if self.owner._logger is not None:
            self.owner._logger.on_message_received(msg)
        self.owner._on_message(msg)

    def on_error(self, exc: Exception) -> None:
        self.owner._on_error(exc)

    def stop(self) -> None:
        pass


def loggable(msg: can.Message) -> can.Message:
    """`msg`, or a copy without its channel when the channel's trailing number does not fit the 16-bit
    channel field of a .blf file (python-can reads "test-8a93b71234" as channel 71234)."""
    ch = can.util.channel2int(msg.channel) if msg.channel is not None else None
    if ch is None or 0 <= ch < 0xFFFF:
        return msg
    return can.Message(timestamp=msg.timestamp, arbitration_id=msg.arbitration_id, data=msg.data,
                       is_extended_id=msg.is_extended_id, is_remote_frame=msg.is_remote_frame,
                       is_error_frame=msg.is_error_frame, dlc=msg.dlc, is_rx=msg.is_rx, check=False)


class _SessionLog(can.Listener):
    """A python-can Logger (.asc/.blf/.log/.csv by suffix) written from two threads: received frames from
    the notifier, sent frames from the control loop."""

    def __init__(self, path: str | Path) -> None:
        self._writer = can.Logger(str(path))
        self._lock = threading.Lock()
        self._open = True

    def on_message_received(self, msg: can.Message) -> None:
        with self._lock:
            if self._open:
                self._writer.on_message_received(loggable(msg))

    def stop(self) -> None:
        with self._lock:
            if self._open:
                self._open = False
                self._writer.stop()


def install_stop_handlers(bus: MotorBus) -> Callable[[], None]:
    """Stop the motors on SIGINT, SIGTERM and interpreter exit. Returns a function that undoes it.

    The handler sends the stop frames from a fresh thread (the interrupted main thread may hold a lock of
    the CAN stack, so sending from the handler itself could deadlock), then raises KeyboardInterrupt
    (SIGINT) or SystemExit(143) (SIGTERM) so that `finally` blocks, `with` exits and atexit run too; each
    calls `stop()` again, which is harmless. Call from the main thread.
    """
    previous = {}

    def handler(signum: int, frame: object) -> None:
        threading.Thread(target=bus.stop, name="cybergear-stop", daemon=False).start()
        if signum == signal.SIGINT:
            raise KeyboardInterrupt
        raise SystemExit(128 + signum)

    for sig in (signal.SIGINT, signal.SIGTERM):
        previous[sig] = signal.signal(sig, handler)
    atexit.register(bus.stop)

    def restore() -> None:
        for sig, h in previous.items():
            with contextlib.suppress(ValueError, TypeError):
                signal.signal(sig, h)
        atexit.unregister(bus.stop)

    return restore


__all__ = ["FAULT_FRAME_FLAG", "CanMotorBus", "install_stop_handlers", "open_bus"]
