"""Interop with an independent implementation, PyPI `python-cybergear` (imports as `cybergear`).

1. Golden frames: for the same command, the project's encoder produces the frame python-cybergear sends.
2. python-cybergear drives the emulator: scan, enable, operation control with known values, parameter
   writes and reads, a fault; the test checks what the emulator decoded and what python-cybergear saw.
"""

from __future__ import annotations

import logging
import math
import struct

import can
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from sparc_quad.sim.cybergear_emulator import CyberGearEmulator
from spine_module.buses.cybergear import protocol as P
from tests.can_util import virtual_rig, wait_for

cybergear = pytest.importorskip("cybergear")
HOST = 0xFD  # python-cybergear's default host id


@pytest.fixture
def rig():
    with virtual_rig(ids=(1, 2, 3), lockstep=False) as r:
        yield r


def _motor(channel: str, can_id: int):
    return cybergear.CyberGearMotor(bus_config={"interface": "virtual", "channel": channel}, can_id=can_id,
                                    host_can_id=HOST, poll_interval=None)


class _Capture:
    """Stands in for python-cybergear's bus.send to capture the frames it would send."""

    def __init__(self) -> None:
        self.frames: list[can.Message] = []

    def send(self, msg: can.Message, timeout: float | None = None) -> None:
        self.frames.append(msg)

    def pop(self) -> list[can.Message]:
        out, self.frames = self.frames, []
        return out


@pytest.fixture
def captured(rig):
    channel, _emu, _sn = rig
    motor = _motor(channel, 1)
    cap = _Capture()
    motor._bus.send = cap.send  # after the real handshake, capture instead of sending
    yield motor, cap
    motor.close()


def _same(ours: can.Message, theirs: can.Message) -> None:
    assert theirs.is_extended_id and ours.is_extended_id
    assert ours.arbitration_id == theirs.arbitration_id, hex(theirs.arbitration_id)
    assert bytes(ours.data) == bytes(theirs.data)


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.floats(-15, 15), st.floats(-14, 14), st.floats(-35, 35), st.floats(-5, 520), st.floats(-1, 6))
def test_golden_operation_control(captured, t, p, v, kp, kd):
    motor, cap = captured  # stateless for this test: each example pops exactly its own frame
    motor.motor_control(t, p, v, kp, kd)
    (theirs,) = cap.pop()
    _same(P.encode_operation_control(1, t, p, v, kp, kd), theirs)


def test_golden_other_commands(captured):
    motor, cap = captured
    motor.enable()
    stop, enable = cap.pop()
    _same(P.encode_stop(1, HOST), stop)
    _same(P.encode_enable(1, HOST), enable)
    motor.disable()
    _same(P.encode_stop(1, HOST), cap.pop()[0])
    motor.reset_zero_position()
    _same(P.encode_set_zero(1, HOST), cap.pop()[0])
    for mode, value in (("operation", 0), ("position", 1), ("speed", 2), ("current", 3)):
        motor.run_mode = mode
        _same(P.encode_param_write(1, "run_mode", value, HOST), cap.pop()[0])
    for name, value in (("iq_ref", 2.5), ("iq_ref", -23.0), ("spd_ref", 7.25), ("limit_torque", 6.0),
                        ("limit_cur", 11.5), ("limit_spd", 3.0)):
        setattr(motor, name, value)
        _same(P.encode_param_write(1, name, value, HOST), cap.pop()[-1])
    motor.loc_ref = 1.5  # python-cybergear writes limit_spd first
    _same(P.encode_param_write(1, "loc_ref", 1.5, HOST), cap.pop()[-1])
    motor._fetch_parameter_list()
    reads = {struct.unpack("<H", m.data[:2])[0]: m for m in cap.pop()}
    for name in ("run_mode", "iq_ref", "spd_ref", "limit_torque", "loc_ref", "limit_spd", "limit_cur",
                 "mechPos", "mechVel", "VBUS"):
        _same(P.encode_param_read(1, name, HOST), reads[P.param_spec(name).index])
    motor.set_can_id(9)  # python-cybergear puts the device uid in the data, we put byte 0 = 1: id only
    assert P.encode_set_can_id(1, 9, HOST).arbitration_id == cap.pop()[0].arbitration_id


def test_scan_finds_emulated_motors(rig):
    channel, _emu, _sn = rig
    found = cybergear.CyberGearMotor.scan(bus_config={"interface": "virtual", "channel": channel},
                                          host_can_id=HOST, timeout=0.3, candidates=[1, 2, 3, 4, 5, 127])
    assert [cid for cid, _ in found] == [1, 2, 3]
    assert all(len(uid) == 8 for _, uid in found)


def test_enable_operation_control_and_feedback(rig):
    channel, emu, _sn = rig
    motor = _motor(channel, 2)
    seen = []
    motor.add_feedback_listener(seen.append)
    try:
        motor.enable()
        assert wait_for(lambda: emu.motors[2].mode == P.MotorMode.RUN)
        assert [type(f) for f in emu.frames_of(P.Frame, 2)][-2:] == [P.Stop, P.Enable]
        assert emu.frames_of(P.Enable, 2)[-1].host_id == HOST
        assert wait_for(lambda: seen and seen[-1].mode == 2)
        emu.load.q[2] = 0.4  # the load sits at 0.4 rad
        motor.motor_control(1.5, 0.7, -2.0, 30.0, 0.8)
        assert wait_for(lambda: len(emu.frames_of(P.OperationControl, 2)) == 1)
        cmd = emu.frames_of(P.OperationControl, 2)[0]
        for got, want, span in ((cmd.torque, 1.5, 24), (cmd.position, 0.7, 25), (cmd.velocity, -2.0, 60),
                                (cmd.kp, 30.0, 500), (cmd.kd, 0.8, 5)):
            assert abs(got - want) <= span / 65535
        tau = emu.motors[2].torque(0.4, 0.0)
        assert tau == pytest.approx(1.5 + 30 * 0.3 - 0.8 * 2.0, abs=0.01)  # firmware law, motor at rest
        assert wait_for(lambda: abs(seen[-1].position - 0.4) < 1e-3)
        assert seen[-1].torque == pytest.approx(tau, abs=24 / 65535)
        assert emu.motors[1].mode == P.MotorMode.RESET  # other motors untouched
    finally:
        motor.close()


def test_parameter_writes_and_reads(rig, caplog):
    channel, emu, _sn = rig
    motor = _motor(channel, 3)
    try:
        motor.run_mode = "current"
        motor.enable()
        motor.iq_ref = 4.0
        motor.limit_torque = 6.0
        motor.limit_cur = 12.0
        assert wait_for(lambda: emu.motors[3].params["limit_cur"] == pytest.approx(12.0))
        m = emu.motors[3]
        assert m.params["run_mode"] == 3 and m.params["iq_ref"] == pytest.approx(4.0)
        assert m.params["limit_torque"] == pytest.approx(6.0)
        assert m.torque(0.0, 0.0, emu.kt) == pytest.approx(4.0 * emu.kt)
        with caplog.at_level(logging.WARNING):
            motor.run_mode = "speed"  # the firmware refuses a mode switch while running
        assert wait_for(lambda: emu.refused)
        assert "while running" in emu.refused[-1] and m.params["run_mode"] == 3
        emu.load.q[3] = -1.25
        motor._fetch_parameter_list()
        assert wait_for(lambda: motor.mech_pos is not None and motor.v_bus is not None)
        assert motor.mech_pos == pytest.approx(-1.25) and motor.v_bus == pytest.approx(24.0)
        assert motor.run_mode == "current"
    finally:
        motor.close()


def test_fault_seen_by_independent_client(rig):
    channel, emu, sniffer = rig
    motor = _motor(channel, 1)
    faults = []
    motor.add_fault_listener(faults.append)
    try:
        motor.enable()
        assert wait_for(lambda: emu.motors[1].mode == P.MotorMode.RUN)
        emu.inject_fault(1, fault_value=1, feedback_bits=1 << P.FeedbackFault.OVER_TEMPERATURE)
        motor.motor_control(0.5, 0, 0, 0, 0)
        assert wait_for(lambda: faults and faults[-1].over_temperature)
        assert faults[-1].has_fault and motor.feedback.mode == P.MotorMode.RESET
        fault_frames = sniffer.of_type(P.CommType.FAULT)
        assert len(fault_frames) == 1
        frame = P.decode_from_motor(fault_frames[0], HOST, {1})
        assert isinstance(frame, P.FaultFrame) and frame.descriptions == ("motor over-temperature",)
        assert emu.motors[1].torque(0.0, 0.0) == 0.0  # a faulted motor gives no torque
        motor.enable()  # python-cybergear's stop has byte 0 = 0: the fault stays latched
        motor.motor_control(0.5, 0, 0, 0, 0)
        assert wait_for(lambda: len(emu.frames_of(P.OperationControl, 1)) == 2)
        assert emu.motors[1].mode == P.MotorMode.RESET
        motor._send_message(cybergear.cybergear.CommunicationTypeCan.motor_stopped, bytes([1]) + bytes(7))
        assert wait_for(lambda: emu.motors[1].fault_value == 0)
        motor.enable()
        assert wait_for(lambda: emu.motors[1].mode == P.MotorMode.RUN)
    finally:
        motor.close()


def test_emulator_can_id_change_answers_from_new_id(rig):
    channel, emu, _sn = rig
    motor = _motor(channel, 3)
    try:
        motor.set_can_id(7)
        assert wait_for(lambda: 7 in emu.motors and 3 not in emu.motors)
    finally:
        motor.close()
    found = cybergear.CyberGearMotor.scan(bus_config={"interface": "virtual", "channel": channel},
                                          host_can_id=HOST, timeout=0.3, candidates=[1, 2, 3, 7])
    assert [cid for cid, _ in found] == [1, 2, 7]


def test_emulator_ignores_frames_for_other_ids():
    bus = can.Bus(interface="virtual", channel="interop-ignore")
    emu = CyberGearEmulator(bus, (1,), start=False)
    emu.handle(P.encode_enable(2))
    emu.handle(can.Message(arbitration_id=P.make_id(1, 0x8000, 1), data=bytes(3), is_extended_id=True))
    assert emu.received == [] and emu.rejected == ["type 1 needs 8 data bytes, got 3"]
    assert not math.isnan(emu.motors[1].torque(0, 0))
    bus.shutdown()
