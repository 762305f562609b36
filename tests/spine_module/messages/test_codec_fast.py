"""The node's one-struct-call decoders (torso state, spine command) accept exactly what the field-by-field
reference decoders accept, return the same values, and raise the same named errors; `encode_state`
writes lcm-gen's bytes."""

from __future__ import annotations

import copy
import math

import numpy as np
import pytest

from spine_module.messages import Fault, MessageError, Mode, SpineState, codec
from spine_module.messages.lcmt.sparc import spine_command_t, spine_state_t, torso_state_t

BAD = (math.nan, math.inf, -math.inf, 1e9, -1e9)


def _num(rng: np.random.Generator, scale: float) -> float:
    """Mostly plausible numbers, sometimes NaN, infinite or far out of range."""
    if rng.random() < 0.04:
        return float(rng.choice(BAD))
    return float(rng.normal(0.0, scale))


def _torso(rng: np.random.Generator) -> bytes:
    m = torso_state_t()
    m.utime = int(rng.integers(-5, 10**12)) if rng.random() < 0.05 else int(rng.integers(0, 10**12))
    m.seq = int(rng.integers(-3, 10**6)) if rng.random() < 0.05 else int(rng.integers(0, 10**6))
    m.q1, m.dq1, m.ddq1 = _num(rng, 1.5), _num(rng, 20.0), _num(rng, 2000.0)
    m.ddq1_valid = int(rng.choice([0, 1, 1, 2, -1]))  # lcm booleans: any non-zero byte is True
    quat = rng.normal(0.0, 1.0, 4)
    quat /= np.linalg.norm(quat) * (1.0 if rng.random() < 0.8 else rng.uniform(0.7, 1.3))
    m.quat = [float(a) if rng.random() > 0.02 else float(rng.choice(BAD)) for a in quat]
    m.omega = [_num(rng, 20.0) for _ in range(3)]
    m.base_accel = [_num(rng, 200.0) for _ in range(3)]
    m.base_accel_valid = int(rng.choice([0, 1, 1, 3]))
    return m.encode()


def _command(rng: np.random.Generator) -> bytes:
    m = spine_command_t()
    m.utime = int(rng.integers(-5, 10**12)) if rng.random() < 0.05 else int(rng.integers(0, 10**12))
    m.seq = int(rng.integers(-3, 10**6)) if rng.random() < 0.05 else int(rng.integers(0, 10**6))
    m.mode = int(rng.integers(-2, 9)) if rng.random() < 0.1 else int(rng.integers(0, 6))
    m.x_d = [abs(_num(rng, 0.2)), _num(rng, 0.2), _num(rng, 1.0)]
    m.dx_d, m.ddx_d = [_num(rng, 2.0) for _ in range(3)], [_num(rng, 200.0) for _ in range(3)]
    m.k = [abs(_num(rng, s)) * (1 if rng.random() > 0.03 else -1) for s in (2000.0, 4000.0, 60.0)]
    m.d = [abs(_num(rng, s)) for s in (80.0, 80.0, 4.0)]
    m.friction_compensation, m.reset = int(rng.choice([0, 1, 3])), int(rng.choice([0, 0, 1, -2]))
    m.tau_ff = [_num(rng, 6.0) for _ in range(3)]
    return m.encode()


def _outcome(fn, data: bytes):
    try:
        return "ok", fn(data)
    except MessageError as exc:
        return type(exc).__name__, str(exc)


def _same(a: object, b: object) -> None:
    assert type(a) is type(b)
    for name, va in vars(a).items():
        vb = getattr(b, name)
        if isinstance(va, np.ndarray):
            np.testing.assert_array_equal(va, vb, err_msg=name)
            assert va.dtype == vb.dtype and va.shape == vb.shape, name
        else:
            assert va == vb and type(va) is type(vb), name


@pytest.mark.parametrize(("make", "fast", "ref"), [
    (_torso, codec.decode_torso, codec.decode_torso_checked),
    (_command, codec.decode_command, codec.decode_command_checked),
], ids=["torso", "command"])
def test_fast_decoder_matches_the_checked_one(make, fast, ref) -> None:
    rng = np.random.default_rng(11)
    kinds = {"ok": 0, "MessageError": 0, "FingerprintError": 0}
    for i in range(3000):
        data = make(rng)
        if i % 50 == 0:
            data = data[:-1] if i % 100 else data + b"\0"
        elif i % 77 == 0:
            data = codec.encode_heartbeat(codec.Heartbeat("x"))
        got, want = _outcome(fast, data), _outcome(ref, data)
        assert got[0] == want[0], (got, want)
        if got[0] == "ok":
            _same(got[1], want[1])
        else:
            assert got[1] == want[1]
        kinds[got[0]] += 1
    assert min(kinds.values()) > 20, kinds  # both outcomes (and a foreign type) really exercised


def test_decoded_messages_share_no_arrays() -> None:
    data = codec.encode_command(codec.SpineCommand(mode=Mode.PD))
    a, b = codec.decode_command(data), codec.decode_command(data)
    a.k[:] = 0.0
    assert b.k.any()


def _state(rng: np.random.Generator) -> SpineState:
    return SpineState(
        stamp_s=float(rng.uniform(0, 1e4)), seq=int(rng.integers(0, 2**40)),
        mode=Mode(int(rng.integers(0, 6))),
        requested_mode=Mode(int(rng.integers(0, 6))), faults=Fault(int(rng.integers(0, 2**14))),
        rejected="".join(rng.choice(list("abc é:.[]")) for _ in range(int(rng.integers(0, 30)))),
        q=rng.normal(size=4), dq=rng.normal(size=4), tau_cmd=rng.normal(size=3), tau_est=rng.normal(size=3),
        x=rng.normal(size=3), dx=np.array([math.nan, 1.0, -2.0]), gain_scale=float(rng.random()),
        load_cell=np.array([1.5, math.nan]), temperature=rng.normal(30, 1, 3), period=1e-3,
        jitter_max=float(rng.random()) * 1e-4, compute=float(rng.random()) * 1e-4,
        feedback_seq=int(rng.integers(-1, 10**6)), command_seq=-1, torso_seq=int(rng.integers(-1, 10**6)))


def test_encode_state_writes_lcm_gens_bytes() -> None:
    rng = np.random.default_rng(5)
    for _ in range(300):
        s = _state(rng)
        m = spine_state_t()
        m.utime, m.seq = round(s.stamp_s * 1e6), s.seq
        m.mode, m.requested_mode = int(s.mode), int(s.requested_mode)
        m.faults, m.rejected = int(s.faults), s.rejected
        m.q, m.dq, m.tau_cmd, m.tau_est = s.q.tolist(), s.dq.tolist(), s.tau_cmd.tolist(), s.tau_est.tolist()
        m.x, m.dx, m.gain_scale = s.x.tolist(), s.dx.tolist(), s.gain_scale
        m.load_cell, m.temperature = s.load_cell.tolist(), s.temperature.tolist()
        m.period, m.jitter_max, m.compute = s.period, s.jitter_max, s.compute
        m.feedback_seq, m.command_seq, m.torso_seq = s.feedback_seq, s.command_seq, s.torso_seq
        assert codec.encode_state(s) == m.encode()


def test_encode_state_refuses_a_wrong_length_array() -> None:
    s = SpineState(q=np.zeros(5), dq=np.zeros(3))  # 8 values in all, like 4 + 4: still an error
    with pytest.raises(ValueError, match="expected 4 values"):
        codec.encode_state(s)


def test_encode_state_of_lists_and_int_arrays_is_the_same_message() -> None:
    s = _state(np.random.default_rng(8))
    ref = codec.encode_state(s)
    s.q, s.tau_cmd, s.temperature = s.q.tolist(), tuple(s.tau_cmd.tolist()), s.temperature.tolist()
    assert codec.encode_state(s) == ref
    s.q = np.array([1, 2, 3, 4])
    s2 = copy.copy(s)
    s2.q = np.array([1.0, 2.0, 3.0, 4.0])
    assert codec.encode_state(s) == codec.encode_state(s2)
