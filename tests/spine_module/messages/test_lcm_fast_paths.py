"""The LCM path's fast paths against their references: the motor feedback/command and torso codecs
(one struct call, one bounds check) give the same bytes, objects and rejections; `update_pose` gives
`update_kinematics`'s x exactly."""

from __future__ import annotations

import numpy as np
import pytest

from spine_module.messages import MessageError, codec
from spine_module.messages.motor import MotorCommand, MotorFeedback

RNG = np.random.default_rng(11)


def _feedback(rng) -> MotorFeedback:
    return MotorFeedback(q=rng.uniform(-12, 12, 3), dq=rng.uniform(-40, 40, 3), tau=rng.uniform(-15, 15, 3),
                         temperature_c=rng.uniform(-40, 200, 3), mode=rng.integers(0, 3, 3).astype(np.int32),
                         fault=rng.integers(0, 64, 3).astype(np.int32),
                         load_cell_n=np.where(rng.random(2) < 0.3, np.nan, rng.uniform(-2000, 2000, 2)),
                         stamp_s=float(rng.integers(0, 10**9)) * 1e-6, seq=int(rng.integers(0, 10**9)))


def _command(rng) -> MotorCommand:
    return MotorCommand(tau_ff=rng.uniform(-12, 12, 3), q_des=rng.uniform(-12, 12, 3),
                        dq_des=rng.uniform(-30, 30, 3), kp=rng.uniform(0, 500, 3), kd=rng.uniform(0, 5, 3),
                        enable=bool(rng.integers(0, 2)), stamp_s=float(rng.integers(0, 10**9)) * 1e-6,
                        seq=int(rng.integers(0, 10**9)))


def _same(a, b) -> None:
    for name in a.__dataclass_fields__:
        x, y = getattr(a, name), getattr(b, name)
        if isinstance(x, np.ndarray):
            np.testing.assert_array_equal(x, y, err_msg=name)
            assert np.asarray(x).dtype == np.asarray(y).dtype, name
        else:
            assert x == y and type(x) is type(y), name


def test_feedback_fast_paths_equal_the_reference():
    for _ in range(500):
        fb = _feedback(RNG)
        data = codec.encode_motor_feedback(fb)
        assert data == codec.encode_motor_feedback_checked(fb)
        _same(codec.decode_motor_feedback(data), codec.decode_motor_feedback_checked(data))


def test_command_fast_paths_equal_the_reference():
    for _ in range(500):
        c, seq = _command(RNG), int(RNG.integers(-1, 10**6))
        data = codec.encode_motor_command(c, seq)
        assert data == codec.encode_motor_command_checked(c, seq)
        (a, sa), (b, sb) = codec.decode_motor_command(data), codec.decode_motor_command_checked(data)
        assert sa == sb == seq
        _same(a, b)


def test_odd_inputs_take_the_general_path():
    fb = _feedback(RNG)
    fb.q, fb.mode = [0.1, 0.2, 0.3], [2, 2, 2]  # lists, not arrays
    assert codec.encode_motor_feedback(fb) == codec.encode_motor_feedback_checked(fb)
    fb.q = np.zeros(4)
    with pytest.raises(ValueError):
        codec.encode_motor_feedback(fb)
    c = _command(RNG)
    c.kp = np.arange(3)  # integers
    assert codec.encode_motor_command(c, 3) == codec.encode_motor_command_checked(c, 3)


@pytest.mark.parametrize("field,value,expect", [
    ("velocity", [0.0, float("nan"), 0.0], "velocity[1]: NaN"),
    ("angle", [0.0, 0.0, 99.0], "angle[2]"),
    ("mode", [0, 3, 2], "mode[1]"),
    ("seq", -1, "seq"),
])
def test_feedback_rejections_are_named_as_before(field, value, expect):
    raw = codec.decode_raw(codec.channels.MOTOR_FEEDBACK, codec.encode_motor_feedback(_feedback(RNG)))
    setattr(raw, field, value)
    data = raw.encode()
    for decode in (codec.decode_motor_feedback, codec.decode_motor_feedback_checked):
        with pytest.raises(MessageError, match=expect.replace("[", r"\[").replace("]", r"\]")):
            decode(data)


def test_command_rejections_are_named_as_before():
    raw = codec.decode_raw(codec.channels.MOTOR_COMMAND, codec.encode_motor_command(_command(RNG), 1))
    raw.kd = [0.0, 0.0, 7.0]
    for decode in (codec.decode_motor_command, codec.decode_motor_command_checked):
        with pytest.raises(MessageError, match=r"kd\[2\]"):
            decode(raw.encode())
    with pytest.raises(MessageError, match="fingerprint"):
        codec.decode_motor_command(codec.encode_motor_feedback(_feedback(RNG)))


def test_torso_encode_fast_path_equals_the_reference():
    from spine_module.messages import TorsoState

    for _ in range(300):
        q = RNG.normal(size=4)
        t = TorsoState(q1=float(RNG.uniform(-3, 3)), dq1=float(RNG.uniform(-50, 50)),
                       ddq1=float(RNG.uniform(-5000, 5000)), ddq1_valid=bool(RNG.integers(0, 2)),
                       quat=q / np.linalg.norm(q), omega=RNG.uniform(-50, 50, 3),
                       stamp_s=float(RNG.integers(0, 10**9)) * 1e-6, seq=int(RNG.integers(0, 10**9)),
                       base_accel=RNG.uniform(-500, 500, 3), base_accel_valid=bool(RNG.integers(0, 2)))
        assert codec.encode_torso(t) == codec.encode_torso_checked(t)
    t.quat = [1.0, 0.0, 0.0, 0.0]  # a list: the general path
    assert codec.encode_torso(t) == codec.encode_torso_checked(t)


def test_update_pose_gives_update_kinematics_x_exactly():
    from spine_module.model import SpineModel

    model = SpineModel()
    full, pose = model.create_data(), model.create_data()
    for _ in range(1000):
        q = RNG.uniform(-1.2, 1.2, 4)
        model.update_kinematics(full, q, RNG.uniform(-5, 5, 4))
        model.update_pose(pose, q)
        np.testing.assert_array_equal(pose.x, full.x)
