"""Encode/decode of every message, validation that names the bad field, fingerprint and framing errors."""

from __future__ import annotations

import math

import numpy as np
import pytest

from spine_module.buses.base import MotorCommand, MotorFeedback
from spine_module.messages import (
    Fault,
    FingerprintError,
    Heartbeat,
    MessageError,
    Mode,
    SpineCommand,
    SpineState,
    TorsoState,
    channels,
    codec,
    decode,
)


def _feedback(**kw) -> MotorFeedback:
    base = dict(q=np.array([-0.9, 1.8, -0.9]), dq=np.array([0.1, -0.2, 0.3]), tau=np.array([1.0, -2.0, 0.5]),
                temperature_c=np.array([30.0, 31.0, 32.0]), mode=np.array([2, 2, 2]),
                fault=np.array([0, 0, 0]), load_cell_n=np.array([1.5, np.nan]), stamp_s=1.234, seq=7)
    base.update(kw)
    return MotorFeedback(**base)


def test_round_trip_every_type():
    t = TorsoState(q1=0.1, dq1=-0.2, ddq1=3.0, ddq1_valid=True, quat=np.array([1.0, 0, 0, 0]),
                   omega=np.array([0.1, 0.2, 0.3]), stamp_s=2.5, seq=3)
    got = decode(channels.TORSO_STATE, codec.encode_torso(t))
    assert (got.q1, got.dq1, got.ddq1, got.ddq1_valid, got.seq, got.stamp_s) == (0.1, -0.2, 3.0, True, 3, 2.5)
    assert got.base_accel.tolist() == [0.0, 0.0, 0.0] and not got.base_accel_valid
    t.base_accel, t.base_accel_valid = np.array([1.5, -0.25, 9.0]), True
    for fn in (codec.decode_torso, codec.decode_torso_checked):
        got = fn(codec.encode_torso(t))
        assert got.base_accel.tolist() == [1.5, -0.25, 9.0] and got.base_accel_valid

    c = SpineCommand(mode=Mode.PD, k=np.array([300.0, 1000.0, 15.0]), tau_ff=np.array([0.1, 0.2, -0.3]),
                     reset=True, friction_compensation=False, stamp_s=0.001, seq=9)
    got = decode(channels.SPINE_COMMAND, codec.encode_command(c))
    assert got.mode == Mode.PD and got.reset and not got.friction_compensation
    np.testing.assert_array_equal(got.k, c.k)
    np.testing.assert_array_equal(got.tau_ff, c.tau_ff)

    fb = decode(channels.MOTOR_FEEDBACK, codec.encode_motor_feedback(_feedback()))
    np.testing.assert_array_equal(fb.q, [-0.9, 1.8, -0.9])
    assert fb.load_cell_n[0] == 1.5 and math.isnan(fb.load_cell_n[1]) and fb.seq == 7

    mc = MotorCommand(tau_ff=np.array([1.0, 2.0, 3.0]), kp=np.array([10.0, 0, 0]), enable=True, seq=4)
    got, answers = decode(channels.MOTOR_COMMAND, codec.encode_motor_command(mc, feedback_seq=41))
    assert answers == 41 and got.enable
    np.testing.assert_array_equal(got.tau_ff, mc.tau_ff)

    hb = decode(channels.HEARTBEAT_ROBOT, codec.encode_heartbeat(Heartbeat("bench-robot", True, 2, 0.5, 8)))
    assert (hb.sender, hb.fault, hb.reset_count, hb.seq) == ("bench-robot", True, 2, 8)

    s = SpineState(mode=Mode.IMPEDANCE, faults=Fault.TORSO_STALE | Fault.ESTOP, rejected="x: y", seq=5)
    got = decode(channels.SPINE_STATE, codec.encode_state(s))
    assert got.faults == Fault.TORSO_STALE | Fault.ESTOP
    assert got.rejected == "x: y" and got.mode == Mode.IMPEDANCE


@pytest.mark.parametrize(("field", "value", "label", "reason"), [
    ("k", [float("nan"), 1000.0, 15.0], "k[0]", "NaN"),
    ("d", [1.0, float("inf"), 0.3], "d[1]", "infinite"),
    ("x_d", [0.273, 0.0, 7.0], "x_d[2]", "outside"),
    ("tau_ff", [0.0, 0.0, -13.0], "tau_ff[2]", "outside"),
    ("k", [-1.0, 1000.0, 15.0], "k[0]", "outside"),
    ("mode", 9, "mode", "not a mode"),
])
def test_bad_command_field_is_named(field, value, label, reason):
    from spine_module.messages.lcmt.sparc import spine_command_t

    raw = codec.decode_raw(channels.SPINE_COMMAND, codec.encode_command(SpineCommand()))
    setattr(raw, field, value)
    with pytest.raises(MessageError) as err:
        decode(channels.SPINE_COMMAND, raw.encode())
    assert err.value.field == label and reason in err.value.reason
    assert str(err.value).startswith(f"SPARC_SPINE_COMMAND.{label}: ")
    assert isinstance(raw, spine_command_t)


@pytest.mark.parametrize(("field", "value", "label"), [
    ("q1", float("nan"), "q1"), ("dq1", float("-inf"), "dq1"), ("q1", 4.0, "q1"),
    ("omega", [0.0, 99.0, 0.0], "omega[1]"), ("quat", [0.5, 0.0, 0.0, 0.0], "quat"),
    ("ddq1", float("nan"), "ddq1"), ("base_accel", [0.0, float("nan"), 0.0], "base_accel[1]"),
    ("base_accel", [float("inf"), 0.0, 0.0], "base_accel[0]"),
    ("base_accel", [0.0, 0.0, -501.0], "base_accel[2]"),
])
def test_bad_torso_field_is_named(field, value, label):
    """ddq1 and base_accel are checked when their flag says they are valid (as an estimator sends them)."""
    raw = codec.decode_raw(channels.TORSO_STATE, codec.encode_torso(TorsoState()))
    raw.ddq1_valid = raw.base_accel_valid = True
    setattr(raw, field, value)
    for fn in (codec.decode_torso, codec.decode_torso_checked):
        with pytest.raises(MessageError) as err:
            fn(raw.encode())
        assert err.value.field == label


def test_torso_ddq1_ignored_when_invalid():
    raw = codec.decode_raw(channels.TORSO_STATE, codec.encode_torso(TorsoState()))
    raw.ddq1, raw.ddq1_valid = float("nan"), False
    assert decode(channels.TORSO_STATE, raw.encode()).ddq1 == 0.0


def test_torso_base_accel_ignored_when_invalid():
    """Not valid: whatever was sent (NaN here) is replaced by 0, as ddq1 is."""
    raw = codec.decode_raw(channels.TORSO_STATE, codec.encode_torso(TorsoState()))
    raw.base_accel, raw.base_accel_valid = [float("nan"), 1e9, 2.0], False
    for fn in (codec.decode_torso, codec.decode_torso_checked):
        got = fn(raw.encode())
        assert got.base_accel.tolist() == [0.0, 0.0, 0.0] and not got.base_accel_valid


@pytest.mark.parametrize(("field", "value", "label"), [
    ("angle", [0.0, float("nan"), 0.0], "angle[1]"), ("velocity", [100.0, 0, 0], "velocity[0]"),
    ("torque", [0, 0, float("inf")], "torque[2]"), ("mode", [2, 7, 2], "mode[1]"),
    ("load_cell", [float("inf"), 0.0], "load_cell[0]"),
])
def test_bad_feedback_field_is_named(field, value, label):
    raw = codec.decode_raw(channels.MOTOR_FEEDBACK, codec.encode_motor_feedback(_feedback()))
    setattr(raw, field, value)
    with pytest.raises(MessageError) as err:
        decode(channels.MOTOR_FEEDBACK, raw.encode())
    assert err.value.field == label


def test_wrong_fingerprint_names_both_types():
    data = codec.encode_torso(TorsoState())
    with pytest.raises(FingerprintError) as err:
        decode(channels.SPINE_COMMAND, data)
    msg = str(err.value)
    assert "expected sparc.spine_command_t" in msg and "got a sparc.torso_state_t" in msg


def test_foreign_fingerprint_is_rejected():
    data = bytearray(codec.encode_command(SpineCommand()))
    data[0] ^= 0xFF
    with pytest.raises(FingerprintError, match="unknown type"):
        decode(channels.SPINE_COMMAND, bytes(data))


@pytest.mark.parametrize("cut", [0, 5, 8, 20, -1])
def test_truncated_message_is_rejected(cut):
    data = codec.encode_command(SpineCommand())
    with pytest.raises(MessageError, match=r"malformed|fingerprint"):
        decode(channels.SPINE_COMMAND, data[:cut])


def test_trailing_bytes_are_rejected():
    with pytest.raises(MessageError, match="trailing"):
        decode(channels.SPINE_COMMAND, codec.encode_command(SpineCommand()) + b"\0")


def test_unknown_channel():
    with pytest.raises(MessageError, match="unknown channel"):
        decode("NOT_OURS", b"12345678")
