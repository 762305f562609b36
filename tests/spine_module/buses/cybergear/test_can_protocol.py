"""CyberGear frame codec: ids, scaling with clamping, parameter table, decoder rejections, fuzzing."""

from __future__ import annotations

import math
import struct

import can
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from spine_module.buses.cybergear import protocol as P
from spine_module.buses.cybergear.busload import bus_load, frame_bits, max_loop_rate_hz


def test_id_layout():
    arb = P.make_id(P.CommType.ENABLE, 0xFD, 0x7F)
    assert arb == 0x0300FD7F
    assert P.split_id(arb) == (3, 0xFD, 0x7F)
    with pytest.raises(ValueError):
        P.make_id(32, 0, 0)


def test_operation_control_layout_and_clamping():
    msg = P.encode_operation_control(5, torque=12.0, position=-12.5, velocity=30.0, kp=500.0, kd=0.0)
    comm, data2, target = P.split_id(msg.arbitration_id)
    assert (comm, data2, target) == (1, 0xFFFF, 5)  # torque in data area 2
    assert struct.unpack(">4H", msg.data) == (0, 0xFFFF, 0xFFFF, 0)
    clamped = P.encode_operation_control(5, torque=99.0, position=-99, velocity=99, kp=1e6, kd=-3)
    assert clamped.arbitration_id == msg.arbitration_id and bytes(clamped.data) == bytes(msg.data)
    with pytest.raises(ValueError, match="non-finite"):
        P.encode_operation_control(5, math.nan, 0, 0, 0, 0)
    # zero torque is the midpoint (truncation as the manual's float_to_uint)
    assert P.split_id(P.encode_operation_control(1, 0, 0, 0, 0, 0).arbitration_id)[1] == 32767


def test_position_range_is_a_setting():
    four_pi = P.encode_operation_control(1, 0, 4 * math.pi, 0, 0, 0, ranges=P.MANUAL_TABLE_RANGES)
    assert struct.unpack(">H", four_pi.data[:2])[0] == 0xFFFF
    default = P.encode_operation_control(1, 0, 4 * math.pi, 0, 0, 0)
    assert struct.unpack(">H", default.data[:2])[0] == 0xFFFF  # 4*pi = 12.566 clamps to 12.5
    inside = P.encode_operation_control(1, 0, 12.5, 0, 0, 0, ranges=P.MANUAL_TABLE_RANGES)
    assert struct.unpack(">H", inside.data[:2])[0] < 0xFFFF


def test_feedback_roundtrip_and_bits():
    msg = P.encode_feedback(3, 0xFD, position=1.25, velocity=-4.0, torque=2.5, temperature_c=41.3,
                            mode=P.MotorMode.RUN, fault_bits=0b000100)
    fb = P.decode_from_motor(msg, host_id=0xFD, motor_ids={3})
    assert isinstance(fb, P.Feedback)
    assert fb.motor_id == 3 and fb.mode == 2 and fb.fault_bits == 4
    assert P.describe_feedback_faults(fb.fault_bits) == ["over temperature"]
    assert abs(fb.position - 1.25) <= 25 / 65535 and abs(fb.velocity + 4.0) <= 60 / 65535
    assert abs(fb.torque - 2.5) <= 24 / 65535 and fb.temperature_c == pytest.approx(41.3)
    assert (msg.arbitration_id >> 22) & 3 == 2 and (msg.arbitration_id >> 18) & 1 == 1


def test_parameter_frames():
    w = P.encode_param_write(1, "iq_ref", 30.0)  # clamped to 23 A
    assert P.split_id(w.arbitration_id) == (18, 0xFD, 1)
    assert struct.unpack("<HHf", w.data) == (0x7006, 0, 23.0)
    rm = P.encode_param_write(1, "run_mode", 3)
    assert bytes(rm.data) == bytes([0x05, 0x70, 0, 0, 3, 0, 0, 0])
    with pytest.raises(ValueError, match="read-only"):
        P.encode_param_write(1, "mechPos", 1.0)
    with pytest.raises(ValueError, match="unknown"):
        P.encode_param_write(1, "nope", 1.0)
    r = P.encode_param_read(1, "VBUS")
    assert bytes(r.data) == bytes([0x1C, 0x70]) + bytes(6)
    reply = P.encode_param_read_reply(1, 0xFD, "VBUS", 24.5)
    dec = P.decode_from_motor(reply, 0xFD)
    assert isinstance(dec, P.ParamReadReply) and dec.value == pytest.approx(24.5) and dec.ok
    for name in ("run_mode", "iq_ref", "spd_ref", "loc_ref", "limit_spd", "limit_cur", "limit_torque",
                 "mechPos", "mechVel", "VBUS"):
        assert P.param_spec(name).index == P.PARAM_BY_NAME[name].index


def test_other_host_to_motor_frames():
    assert P.decode_to_motor(P.encode_stop(2, clear_fault=True)) == P.Stop(2, 0xFD, clear_fault=True)
    assert P.decode_to_motor(P.encode_set_zero(2)) == P.SetZero(2, 0xFD)
    sid = P.encode_set_can_id(2, 9)
    assert P.split_id(sid.arbitration_id) == (7, (9 << 8) | 0xFD, 2)
    assert P.decode_to_motor(sid) == P.SetCanId(2, 0xFD, new_id=9)
    dev = P.decode_from_motor(P.encode_device_id(4, bytes(range(8))), 0xFD)
    assert dev == P.DeviceId(4, 0xFD, uid=bytes(range(8)))
    fault = P.decode_from_motor(P.encode_fault(4, 0xFD, fault_value=(1 << 3) | (1 << 9)), 0xFD)
    assert isinstance(fault, P.FaultFrame) and "overvoltage" in fault.descriptions
    assert any("overload" in d for d in fault.descriptions)


@pytest.mark.parametrize("msg,reason", [
    (can.Message(arbitration_id=P.make_id(2, 0x8001, 0xFD), data=bytes(5), is_extended_id=True),
     "needs 8 data bytes"),
    (can.Message(arbitration_id=P.make_id(2, 0x8001, 0x00), data=bytes(8), is_extended_id=True),
     "addressed to host"),
    (can.Message(arbitration_id=P.make_id(2, 0x8009, 0xFD), data=bytes(8), is_extended_id=True),
     "not configured"),
    (can.Message(arbitration_id=P.make_id(1, 0x8000, 0x01), data=bytes(8), is_extended_id=True),
     "not a motor -> host type"),
    (can.Message(arbitration_id=0x123, data=bytes(8), is_extended_id=False), "standard 11-bit"),
    (can.Message(arbitration_id=P.make_id(2, 0x8001, 0xFD), is_remote_frame=True, dlc=8,
                 is_extended_id=True), "remote frame"),
])
def test_decoder_rejects_with_reason(msg, reason):
    with pytest.raises(P.FrameError, match=reason):
        P.decode_from_motor(msg, host_id=0xFD, motor_ids={1, 2, 3})


def test_motor_side_decoder_rejects():
    with pytest.raises(P.FrameError, match="addressed to motor 9"):
        P.decode_to_motor(P.encode_enable(9), motor_ids={1})
    short = can.Message(arbitration_id=P.make_id(1, 0x8000, 1), data=bytes(7), is_extended_id=True)
    with pytest.raises(P.FrameError, match="needs 8 data bytes"):
        P.decode_to_motor(short)
    bad_index = can.Message(arbitration_id=P.make_id(18, 0xFD, 1), data=bytes(8), is_extended_id=True)
    with pytest.raises(P.FrameError, match="unknown parameter"):
        P.decode_to_motor(bad_index)
    with pytest.raises(P.FrameError, match="not a host -> motor"):
        P.decode_to_motor(P.encode_feedback(1, 0xFD, 0, 0, 0, 25))


def _frames():
    return st.builds(
        lambda arb, data, ext, remote, dlc_extra: can.Message(
            arbitration_id=arb if ext else arb & 0x7FF, data=None if remote else data, is_extended_id=ext,
            is_remote_frame=remote, dlc=(len(data) if not remote else dlc_extra), check=False),
        st.one_of(st.integers(0, P.ID_MASK_29),
                  st.builds(P.make_id, st.sampled_from([0, 1, 2, 3, 4, 6, 7, 17, 18, 21, 5, 22]),
                            st.integers(0, 0xFFFF), st.sampled_from([0, 1, 2, 3, 0x7F, 0xFD, 0xFE]))),
        st.binary(min_size=0, max_size=8), st.booleans(), st.booleans(), st.integers(0, 8))


@settings(max_examples=400, deadline=None)
@given(_frames())
def test_fuzz_decoders_only_return_frames_or_frameerror(msg):
    for decode in (lambda m: P.decode_from_motor(m, 0xFD, {1, 2, 3}),
                   lambda m: P.decode_to_motor(m, {1, 2, 3}), P.decode_from_motor, P.decode_to_motor):
        try:
            frame = decode(msg)
        except P.FrameError as e:
            assert e.reason
        else:
            assert isinstance(frame, P.Frame)
            assert msg.is_extended_id and not msg.is_remote_frame


@settings(max_examples=200, deadline=None)
@given(st.floats(-20, 20), st.floats(-15, 15), st.floats(-40, 40), st.floats(-10, 600), st.floats(-1, 6))
def test_operation_control_roundtrip_within_one_lsb(t, p, v, kp, kd):
    frame = P.decode_to_motor(P.encode_operation_control(1, t, p, v, kp, kd))
    assert isinstance(frame, P.OperationControl)
    for got, want, lo, hi in ((frame.torque, t, -12, 12), (frame.position, p, -12.5, 12.5),
                              (frame.velocity, v, -30, 30), (frame.kp, kp, 0, 500), (frame.kd, kd, 0, 5)):
        want = min(max(want, lo), hi)
        assert want - (hi - lo) / 65535 * 1.0001 <= got <= want + 1e-9


def test_bus_load_model():
    assert frame_bits(8, True, False) == 131 and frame_bits(8, True, True) == 160
    assert frame_bits(0, False, False) == 47  # classic 11-bit frame without data
    load = bus_load(3, 1000.0, 1_000_000, warn=False)
    assert load.frames_per_s == 6000
    assert load.utilisation_nominal == pytest.approx(0.786) and load.utilisation_worst == pytest.approx(0.96)
    assert load.over_warning
    assert max_loop_rate_hz(3) == pytest.approx(833.33, abs=0.01)
    assert max_loop_rate_hz(3, utilisation=1.0) == pytest.approx(1041.67, abs=0.01)
    assert not bus_load(3, 500.0, warn=False).over_warning


def test_bus_load_warns(caplog):
    with caplog.at_level("WARNING"):
        bus_load(3, 1000.0)
    assert "exceeds 80 %" in caplog.text and "833 Hz" in caplog.text


class _NullBus(can.BusABC):
    def __init__(self) -> None:
        super().__init__(channel="null")
        self.sent: list[can.Message] = []

    def send(self, msg, timeout=None):
        self.sent.append(msg)

    def _recv_internal(self, timeout):
        return None, False


@settings(max_examples=300, deadline=None)
@given(_frames())
def test_fuzz_emulator_never_raises_and_answers_with_valid_frames(msg):
    from sparc_quad.sim.cybergear_emulator import CyberGearEmulator
    bus = _NullBus()
    emu = CyberGearEmulator(bus, (1, 2, 3), start=False)
    emu.handle(msg)
    for reply in bus.sent:  # whatever it answers decodes as a motor -> host frame
        assert isinstance(P.decode_from_motor(reply), P.Frame)
    bus.shutdown()
