"""A CyberGear emulator: answers CAN frames as the motor firmware does, for tests and simulation.

Behaviour modelled (CyberGear instruction manual, section 4):
- mode state machine: RESET after power-up and after stop (type 4), RUN after enable (type 3); a fault
  (injected) drops to RESET and is cleared only by a stop frame with byte 0 = 1; enabling a faulted motor
  leaves it in RESET;
- run_mode (0 operation, 1 position, 2 speed, 3 current) is written with type 18 and, as the manual's
  precaution says, only while stopped: a write while running is refused (recorded in `refused`);
- replies: get id (0) and set id (7) -> device-id frame (type 0, target 0xFE); operation control (1),
  enable (3), stop (4), set zero (6), parameter write (18) -> feedback (type 2); read (17) -> read reply;
- the parameter table of `protocol.PARAMS` (limits clamped as the firmware does);
- output torque: operation control by `MotorCommand.torque` (the one motor law), current mode
  tau = kt * iq_ref, simple speed/position loops; clamped to limit_torque; zero unless RUN;
- CAN timeout (parameter CAN_TIMEOUT, 0x200C, 1/20000 s per count, 0 = off; see protocol.py for the
  source and what is assumed): a RUN motor that has received no frame addressed to it for that long
  drops to RESET (zero torque), checked on the emulator's own clock (wall time in real time, simulated
  time in lockstep) before every load step and by `check_can_timeouts()`; each trip is recorded in
  `timeout_trips` (motor, last frame s, trip s);
- fault injection (`inject_fault`: feedback fault bits and a type-21 frame), a motor that stops answering
  (`set_silent`), malformed frames (`send_malformed`).

INTERPRETATION: a type-1 frame carries no host id; the emulator answers to the host id seen last in any
other frame (initially `host_id`), which is how drivers that filter on bits 15..8 see the real motor.

Physics: a `Load` supplies each motor's output position/velocity and receives its torque. `FreeLoad`
is a rotor-plus-load inertia per motor; `CallbackLoad` couples any simulation (the pybullet bench spine).
With `lockstep=True` the emulator holds the feedback to a cycle's frame (operation control, an iq_ref
write, or a plain stop, which is what a host sends each cycle while it holds the motors stopped; a stop
that clears faults is a handshake frame, answered at once) until every answering motor has had one,
steps the load by `dt` with the resulting torques, then answers all:
the node's next cycle sees the state after the step, deterministically and as fast as the host allows.
Without lockstep, replies are immediate and `run(stop_event)` steps the load in real time.
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from typing import Protocol

import can

from spine_module.buses.cybergear import protocol as P
from spine_module.buses.cybergear.config import KT_NM_PER_A
from spine_module.buses.cybergear.driver import loggable
from spine_module.messages.motor import MotorCommand

log = logging.getLogger(__name__)


class Load(Protocol):
    def read(self, motor_id: int) -> tuple[float, float]:
        """Output-shaft position (rad) and velocity (rad/s) of a motor."""

    def step(self, torques: dict[int, float], dt: float) -> None:
        """Apply output torques (N*m) for dt seconds."""


class FreeLoad:
    """Each motor drives its own inertia with viscous damping (semi-implicit Euler)."""

    def __init__(self, ids: Iterable[int], inertia_kg_m2: float = 0.01, damping_nm_s_rad: float = 0.01,
                 q0: dict[int, float] | None = None) -> None:
        self.q = {i: (q0 or {}).get(i, 0.0) for i in ids}
        self.dq = dict.fromkeys(self.q, 0.0)
        self.inertia, self.damping = inertia_kg_m2, damping_nm_s_rad

    def read(self, motor_id: int) -> tuple[float, float]:
        return self.q.get(motor_id, 0.0), self.dq.get(motor_id, 0.0)

    def step(self, torques: dict[int, float], dt: float) -> None:
        for i in self.q:
            acc = (torques.get(i, 0.0) - self.damping * self.dq[i]) / self.inertia
            self.dq[i] += acc * dt
            self.q[i] += self.dq[i] * dt


class CallbackLoad:
    """Couple a simulation through two functions: read(motor_id) -> (q, dq); step(torques, dt)."""

    def __init__(self, read: Callable[[int], tuple[float, float]],
                 step: Callable[[dict[int, float], float], None]) -> None:
        self.read = read  # type: ignore[method-assign]
        self.step = step  # type: ignore[method-assign]


@dataclass
class EmulatedMotor:
    can_id: int
    uid: bytes
    mode: int = P.MotorMode.RESET
    fault_bits: int = 0
    fault_value: int = 0
    stuck_fault_bits: int = 0  # feedback fault bits a clear cannot remove (e.g. not calibrated)
    warning_value: int = 0
    silent: bool = False
    zero_rad: float = 0.0  # physical position of the mechanical zero (type 6)
    temperature_c: float = 30.0
    cmd: MotorCommand = field(default_factory=lambda: MotorCommand(0.0, 0.0, 0.0, 0.0, 0.0))  # scalars
    params: dict[str, float | int] = field(default_factory=lambda: {
        "run_mode": 0, "iq_ref": 0.0, "spd_ref": 0.0, "limit_torque": 12.0, "cur_kp": 0.125,
        "cur_ki": 0.0158, "cur_filt_gain": 0.1, "loc_ref": 0.0, "limit_spd": 2.0, "limit_cur": 23.0,
        "rotation": 0, "loc_kp": 30.0, "spd_kp": 1.0, "spd_ki": 0.002, "VBUS": 24.0, "CAN_TIMEOUT": 0})
    last_torque: float = 0.0
    last_rx_s: float | None = None  # emulator clock of the last frame addressed to this motor
    last_torque_s: float | None = None  # emulator clock of the last load step with non-zero torque

    def can_timeout_s(self) -> float:
        return int(self.params.get("CAN_TIMEOUT", 0)) / P.CAN_TIMEOUT_TICKS_PER_S

    def torque(self, p: float, v: float, kt: float = KT_NM_PER_A) -> float:
        """Output torque for output-side position p (after the zero offset) and velocity v."""
        if self.mode != P.MotorMode.RUN or self.fault_bits or self.fault_value:
            return 0.0
        run_mode = int(self.params["run_mode"])
        if run_mode == P.RunMode.OPERATION:
            tau = float(self.cmd.torque(p, v))
        elif run_mode == P.RunMode.CURRENT:
            tau = kt * float(self.params["iq_ref"])
        else:
            lim_i = float(self.params["limit_cur"])
            if run_mode == P.RunMode.POSITION:
                lim_v = float(self.params["limit_spd"])
                v_ref = min(max(float(self.params["loc_kp"]) * (float(self.params["loc_ref"]) - p), -lim_v),
                            lim_v)
            else:
                v_ref = float(self.params["spd_ref"])
            iq = min(max(float(self.params["spd_kp"]) * (v_ref - v), -lim_i), lim_i)
            tau = kt * iq
        lim = float(self.params["limit_torque"])
        return min(max(tau, -lim), lim)


class CyberGearEmulator:
    """Emulated CyberGear motors on a python-can bus (see module docstring)."""

    def __init__(self, bus: can.BusABC, ids: Iterable[int] = (1, 2, 3), load: Load | None = None, *,
                 host_id: int = P.DEFAULT_HOST_ID, ranges: P.Ranges = P.DEFAULT_RANGES,
                 lockstep: bool = False, dt: float = 0.001, kt_nm_per_a: float = KT_NM_PER_A,
                 start: bool = True, log: can.Listener | None = None,
                 clock: Callable[[], float] | None = None) -> None:
        ids = list(ids)
        self.bus = bus
        self.motors: dict[int, EmulatedMotor] = {
            i: EmulatedMotor(i, uid=bytes([0xC6, 0xB0, 0, 0, 0, 0, 0x10, i])) for i in ids}
        self.load: Load = load if load is not None else FreeLoad(ids)
        self._load_id = {i: i for i in ids}  # motor id -> load id (stable across set-id)
        self.host_id = host_id
        self.ranges = ranges
        self.lockstep = lockstep
        self.dt = dt
        self.kt = kt_nm_per_a
        self.lock = threading.RLock()
        # the emulator's own clock (CAN timeout, timeout_trips), s: wall time when it runs in real time;
        # in lockstep its simulated time (steps x dt), which only moves when the host commands a step, so
        # a slow host never trips the CAN timeout there (and a dead host freezes the load)
        self.clock = clock if clock is not None else (self._sim_time if lockstep else time.monotonic)
        self.timeout_trips: list[tuple[int, float, float]] = []  # (motor id, last frame s, tripped s)
        self.received: list[P.Frame] = []  # every decoded frame addressed to an emulated motor
        self.rejected: list[str] = []  # reasons for frames addressed to us that the firmware would drop
        self.refused: list[str] = []  # commands a real motor would refuse (mode switch while running)
        self.sent = 0
        self.steps = 0
        self.late_rephases = 0  # free-running: times the load fell > 5 steps behind and re-phased
        self.keep_log = True
        self._pending: set[int] = set()  # commanded this lockstep cycle
        self.log = log  # a python-can Logger: frames received and sent
        self._notifier: can.Notifier | None = can.Notifier(bus, [self._on_message], timeout=0.05) \
            if start else None

    # --- physics -------------------------------------------------------------------------------------
    def _state(self, m: EmulatedMotor) -> tuple[float, float]:
        q, dq = self.load.read(self._load_id[m.can_id])
        return q - m.zero_rad, dq

    def torques(self) -> dict[int, float]:
        out = {}
        for m in self.motors.values():
            p, v = self._state(m)
            m.last_torque = m.torque(p, v, self.kt)
            out[self._load_id[m.can_id]] = m.last_torque
        return out

    def _sim_time(self) -> float:
        return self.steps * self.dt

    def check_can_timeouts(self, now: float | None = None) -> None:
        """Drop every RUN motor whose CAN timeout has passed without a frame to RESET (zero torque)."""
        with self.lock:
            now = self.clock() if now is None else now
            for m in self.motors.values():
                limit = m.can_timeout_s()
                if (limit > 0 and m.mode == P.MotorMode.RUN and m.last_rx_s is not None
                        and now - m.last_rx_s >= limit):
                    m.mode = P.MotorMode.RESET
                    self.timeout_trips.append((m.can_id, m.last_rx_s, now))
                    log.warning("motor %d: no frame for %.1f ms: CAN timeout, stopped", m.can_id,
                                (now - m.last_rx_s) * 1e3)

    def step(self, dt: float | None = None) -> None:
        with self.lock:
            now = self.clock()
            self.check_can_timeouts(now)
            torques = self.torques()
            for m in self.motors.values():
                if m.last_torque != 0.0:
                    m.last_torque_s = now
            self.load.step(torques, self.dt if dt is None else dt)
            self.steps += 1

    def run(self, stop: threading.Event, realtime: bool = True) -> None:
        """Step the load every dt until `stop` is set (free-running mode)."""
        t_next = time.perf_counter()
        while not stop.is_set():
            self.step()
            if realtime:  # absolute schedule: a late step is made up, unless far (> 5 steps) behind
                t_next += self.dt
                delay = t_next - time.perf_counter()
                if delay > 0:
                    time.sleep(delay)
                elif delay < -5 * self.dt:
                    self.late_rephases += 1
                    t_next = time.perf_counter()

    # --- frames out ----------------------------------------------------------------------------------
    def _tx(self, msg: can.Message) -> None:
        try:
            self.bus.send(msg, timeout=0.1)
            self.sent += 1
            if self.log is not None:
                self.log.on_message_received(loggable(msg))
        except can.CanError as e:  # a real motor's transmit failures are invisible to it too
            log.warning("emulator send failed: %s", e)

    def _feedback(self, m: EmulatedMotor) -> can.Message:
        p, v = self._state(m)
        fb_tau = m.last_torque if m.mode == P.MotorMode.RUN else 0.0
        return P.encode_feedback(m.can_id, self.host_id, p, v, fb_tau, m.temperature_c, m.mode,
                                 m.fault_bits, self.ranges)

    def _reply_feedback(self, m: EmulatedMotor) -> None:
        if not m.silent:
            self._tx(self._feedback(m))

    # --- frames in -----------------------------------------------------------------------------------
    def _on_message(self, msg: can.Message) -> None:
        with self.lock:
            if self.log is not None:
                self.log.on_message_received(loggable(msg))
            self.handle(msg)

    def handle(self, msg: can.Message) -> None:
        if not msg.is_extended_id or msg.is_error_frame:
            return
        comm, _data2, target = P.split_id(msg.arbitration_id)
        m = self.motors.get(target)
        if m is None or m.silent:
            return  # not addressed to an (answering) emulated motor
        try:
            frame = P.decode_to_motor(msg, {target}, self.ranges)
        except P.FrameError as e:
            if comm not in (P.CommType.FEEDBACK, P.CommType.FAULT):  # echoes of motor frames: ignore
                self.rejected.append(e.reason)
            return
        m.last_rx_s = self.clock()
        if self.keep_log:
            self.received.append(frame)
        if not isinstance(frame, P.OperationControl) and frame.host_id != target:
            self.host_id = frame.host_id
        if isinstance(frame, P.GetId):
            self._tx(P.encode_device_id(m.can_id, m.uid))
        elif isinstance(frame, P.OperationControl):
            m.cmd = MotorCommand(frame.torque, frame.position, frame.velocity, frame.kp, frame.kd)
            self._commanded(m)
        elif isinstance(frame, P.Enable):
            m.fault_bits |= m.stuck_fault_bits
            if not (m.fault_bits or m.fault_value):
                m.mode = P.MotorMode.RUN
            self.torques()
            self._reply_feedback(m)
        elif isinstance(frame, P.Stop):
            m.mode = P.MotorMode.RESET
            if frame.clear_fault:
                m.fault_bits, m.fault_value, m.warning_value = m.stuck_fault_bits, 0, 0
                self._pending.discard(m.can_id)
                self._reply_feedback(m)
            else:  # a host holding its motors stopped sends one plain stop per cycle
                self._commanded(m)
        elif isinstance(frame, P.SetZero):
            m.zero_rad = self.load.read(self._load_id[m.can_id])[0]
            self._reply_feedback(m)
        elif isinstance(frame, P.SetCanId):
            if frame.new_id in self.motors and frame.new_id != m.can_id:
                self.refused.append(f"set id {m.can_id} -> {frame.new_id}: id in use")
                return
            del self.motors[m.can_id]
            self._load_id[frame.new_id] = self._load_id.pop(m.can_id)
            m.can_id = frame.new_id
            self.motors[m.can_id] = m
            self._tx(P.encode_device_id(m.can_id, m.uid))
        elif isinstance(frame, P.ParamRead):
            spec = P.PARAM_BY_INDEX[frame.index]
            self._tx(P.encode_param_read_reply(m.can_id, self.host_id, spec.index, self._read_param(m, spec)))
        elif isinstance(frame, P.ParamWrite):
            self._write_param(m, P.PARAM_BY_INDEX[frame.index], frame.value)

    def _read_param(self, m: EmulatedMotor, spec: P.ParamSpec) -> float | int:
        p, v = self._state(m)
        dynamic = {"mechPos": p, "mechVel": v, "iqf": m.last_torque / self.kt}
        return dynamic.get(spec.name, m.params.get(spec.name, 0))

    def _write_param(self, m: EmulatedMotor, spec: P.ParamSpec, value: float | int) -> None:
        if not spec.writable:
            self.refused.append(f"motor {m.can_id}: {spec.name} is read-only")
        elif spec.name == "run_mode" and m.mode == P.MotorMode.RUN and value != m.params["run_mode"]:
            self.refused.append(f"motor {m.can_id}: run_mode change to {value} while running")
        elif spec.name == "run_mode" and value not in (0, 1, 2, 3):
            self.refused.append(f"motor {m.can_id}: run_mode {value} unknown")
        else:
            if spec.lo is not None and spec.hi is not None:
                value = type(value)(min(max(value, spec.lo), spec.hi))
            m.params[spec.name] = value
        if spec.name == "iq_ref" and m.mode == P.MotorMode.RUN:  # a running motor's per-cycle command
            self._commanded(m)
        else:
            self.torques()
            self._reply_feedback(m)

    def _commanded(self, m: EmulatedMotor) -> None:
        if not self.lockstep:
            self.torques()
            self._reply_feedback(m)
            return
        self._pending.add(m.can_id)
        answering = {i for i, mm in self.motors.items() if not mm.silent}
        if answering <= self._pending:
            self.step()
            self.torques()  # torques at the new state, reported in the feedback
            for i in sorted(self._pending):
                self._reply_feedback(self.motors[i])
            self._pending.clear()

    # --- fault injection -----------------------------------------------------------------------------
    def inject_fault(self, motor_id: int, fault_value: int = 1, feedback_bits: int = 1 << 2,
                     send_frame: bool = True) -> None:
        """Latch a fault (default: over-temperature), drop to RESET and send a type-21 frame."""
        with self.lock:
            m = self.motors[motor_id]
            m.fault_value, m.fault_bits, m.mode = fault_value, feedback_bits, P.MotorMode.RESET
            if send_frame and not m.silent:
                self._tx(P.encode_fault(m.can_id, self.host_id, fault_value, m.warning_value))

    def set_silent(self, motor_id: int, silent: bool = True) -> None:
        """A motor that stops answering (power or wire lost): it ignores and sends nothing."""
        with self.lock:
            self.motors[motor_id].silent = silent
            if silent:
                self._pending.discard(motor_id)

    def send_malformed(self, motor_id: int, dlc: int = 5) -> None:
        """A feedback-typed frame from `motor_id` with a wrong length."""
        with self.lock:
            good = self._feedback(self.motors[motor_id])
            self._tx(can.Message(arbitration_id=good.arbitration_id, data=bytes(good.data[:dlc]),
                                 is_extended_id=True))

    def frames_of(self, kind: type, motor_id: int | None = None) -> list:
        with self.lock:
            return [f for f in self.received if isinstance(f, kind)
                    and (motor_id is None or f.motor_id == motor_id)]

    def shutdown(self) -> None:
        if self._notifier is not None:
            self._notifier.stop()
            self._notifier = None
        with self.lock:
            if self.log is not None:
                self.log.stop()
                self.log = None


def parse_ids(text: str) -> list[int]:
    ids = [int(t, 0) for t in text.split(",") if t.strip()]
    if not ids or any(not 1 <= i <= 0x7F for i in ids):
        raise ValueError(f"ids must be a comma-separated list of 1..127, got {text!r}")
    return ids


__all__ = ["CallbackLoad", "CyberGearEmulator", "EmulatedMotor", "FreeLoad", "Load", "parse_ids"]
