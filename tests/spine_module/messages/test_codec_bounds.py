"""`codec.Bounds`, the one bounds description per message type (built from its layout and the `*_RANGES`
tables): every checked value is at the flat index its label names, the bounds are inclusive, the first
bad field in table order is named, and the fast decoders and the field-by-field ones reject alike (also
for the motor messages, fuzzed, and the types without a fixed layout: heartbeat and spine state)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from spine_module.messages import (
    Heartbeat,
    MessageError,
    Mode,
    SpineCommand,
    SpineState,
    TorsoState,
    channels,
    codec,
)
from spine_module.messages.lcmt.sparc import (
    heartbeat_t,
    motor_command_t,
    motor_feedback_t,
    spine_command_t,
    spine_state_t,
    torso_state_t,
)
from spine_module.messages.motor import MotorCommand, MotorFeedback
from spine_module.workspace import SPARC

_FB = MotorFeedback(q=np.zeros(3), dq=np.zeros(3), tau=np.zeros(3), temperature_c=np.full(3, 30.0),
                    mode=np.full(3, 2, dtype=np.int32), fault=np.zeros(3, dtype=np.int32),
                    load_cell_n=np.array([1.0, math.nan]), stamp_s=1.0, seq=4)
# type: (channel, a valid message's bytes, its decoders: fast first when there is one, then the reference)
CASES = {
    torso_state_t: (channels.TORSO_STATE, codec.encode_torso(TorsoState(ddq1_valid=True)),
                    (codec.decode_torso, codec.decode_torso_checked)),
    # DAMPING: each x_d element alone at its range's edge is no reachable target; targets are checked as a
    # whole in the modes that use them (test_workspace_targets.py)
    spine_command_t: (channels.SPINE_COMMAND, codec.encode_command(SpineCommand(mode=Mode.DAMPING)),
                      (codec.decode_command, codec.decode_command_checked)),
    motor_feedback_t: (channels.MOTOR_FEEDBACK, codec.encode_motor_feedback(_FB),
                       (codec.decode_motor_feedback, codec.decode_motor_feedback_checked)),
    motor_command_t: (channels.MOTOR_COMMAND, codec.encode_motor_command(MotorCommand(tau_ff=np.zeros(3)), 3),
                      (codec.decode_motor_command, codec.decode_motor_command_checked)),
    heartbeat_t: (channels.HEARTBEAT_NODE, codec.encode_heartbeat(Heartbeat("node", seq=2)),
                  (codec.decode_heartbeat, codec.decode_heartbeat_checked)),
    spine_state_t: (channels.SPINE_STATE, codec.encode_state(SpineState()), (codec.decode_state,)),
}
BOUNDS = {torso_state_t: codec._TORSO_BOUNDS[1], spine_command_t: codec.SPARC_COMMANDS.bounds,
          motor_feedback_t: codec._FEEDBACK_BOUNDS, motor_command_t: codec._MCMD_BOUNDS,
          heartbeat_t: codec._HEARTBEAT_BOUNDS, spine_state_t: codec._STATE_BOUNDS}


def test_every_message_type_has_its_bounds() -> None:
    assert set(BOUNDS) == set(codec.LCM_TYPES) == set(CASES)
    assert codec._TORSO_BOUNDS[0].layout is codec._TORSO_BOUNDS[1].layout
    labels = [label for _i, label, _r in codec._TORSO_BOUNDS[0].checks]
    assert "ddq1" not in labels
    assert labels == [x for _i, x, _r in codec._TORSO_BOUNDS[1].checks if x != "ddq1"]


def _outcomes(decoders, data: bytes) -> list[str]:
    out = []
    for fn in decoders:
        try:
            fn(data, CASES_BY_FN[fn])
            out.append("ok")
        except MessageError as exc:
            out.append(f"{type(exc).__name__}: {exc}")
    return out


CASES_BY_FN = {fn: ch for ch, _data, fns in CASES.values() for fn in fns}


def _with(cls: type, values: dict[int, float | int]) -> bytes:
    layout = BOUNDS[cls].layout
    _ch, data, _fns = CASES[cls]
    vals = list(layout.unpack(data))
    if cls is torso_state_t and any(i in values for i in range(codec._T_QUAT, codec._T_QUAT + 4)):
        vals[codec._T_QUAT:codec._T_QUAT + 4] = [0.0] * 4  # one component alone: norm 1 at its bound
    for i, v in values.items():
        vals[i] = v
    return layout.pack(vals)


def _just_outside(r: codec.Range, sent: float | int) -> float | int:
    if isinstance(sent, int):
        return int(r.lo) - 1 if r.lo > -math.inf else int(r.hi) + 1
    return float(np.nextafter(r.hi, math.inf)) if r.hi < math.inf else float(np.nextafter(r.lo, -math.inf))


@pytest.mark.parametrize("cls", list(CASES), ids=lambda c: c.__name__)
def test_each_checked_value_is_named_by_its_label_and_its_bounds_are_inclusive(cls) -> None:
    channel, data, decoders = CASES[cls]
    assert _outcomes(decoders, data) == ["ok"] * len(decoders)
    sent = BOUNDS[cls].layout.unpack(data)
    assert BOUNDS[cls].checks, cls
    for i, label, r in BOUNDS[cls].checks:
        for edge in (r.lo, r.hi):
            if math.isfinite(edge):
                v = int(edge) if isinstance(sent[i], int) else edge
                assert _outcomes(decoders, _with(cls, {i: v})) == ["ok"] * len(decoders), (label, v)
        bad = _just_outside(r, sent[i])
        got = _outcomes(decoders, _with(cls, {i: bad}))
        assert len(set(got)) == 1 and got[0].startswith(f"MessageError: {channel}.{label}: "), (label, got)
        if not isinstance(sent[i], int):
            nan = _outcomes(decoders, _with(cls, {i: math.nan}))
            assert nan == (["ok"] * len(decoders) if r.nan_ok else [f"MessageError: {channel}.{label}: NaN"]
                           * len(decoders)), (label, nan)


@pytest.mark.parametrize(("cls", "bad", "named"), [
    (torso_state_t, {"utime": -1, "seq": -2, "q1": math.nan}, "seq: -2 is negative"),
    (torso_state_t, {"utime": -1, "q1": math.inf}, "utime: -1 is negative"),
    (spine_command_t, {"mode": 7, "k": 1e9}, "mode: 7 is not a mode (0..5)"),
    (spine_command_t, {"tau_ff": -math.inf, "x_d": 9.0}, f"x_d[0]: 9 outside [0, {SPARC.reach_m:.6g}] m"),
    (motor_feedback_t, {"mode": 5, "load_cell": math.inf}, "load_cell[0]: inf (infinite)"),
    (motor_feedback_t, {"mode": -1}, "mode[0]: -1 is not a motor mode (0 reset, 1 cal, 2 run)"),
    (motor_command_t, {"kd": 6.0, "position": math.nan}, "position[0]: NaN"),
    (heartbeat_t, {"utime": -5, "seq": -1}, "seq: -1 is negative"),
    (spine_state_t, {"requested_mode": 6, "mode": -1}, "mode: -1 is not a mode (0..5)"),
    (spine_state_t, {"requested_mode": 6}, "requested_mode: 6 is not a mode (0..5)"),
])
def test_the_first_bad_field_in_table_order_is_named(cls, bad, named) -> None:
    layout = BOUNDS[cls].layout
    channel, _data, decoders = CASES[cls]
    got = _outcomes(decoders, _with(cls, {layout.index(name)[0]: v for name, v in bad.items()}))
    assert got == [f"MessageError: {channel}.{named}"] * len(decoders)


def test_unbounded_values_may_be_nan() -> None:
    """A NaN where no range applies fails the one comparison but names no field: the message is accepted."""
    s = codec.decode_state(codec.encode_state(SpineState(dx=np.array([math.nan, 1.0, 2.0]), period=math.nan)))
    assert math.isnan(s.dx[0]) and math.isnan(s.period)
    a = codec._T_DDQ1
    for fn in (codec.decode_torso, codec.decode_torso_checked):
        t = fn(_with(torso_state_t, {a: math.nan, codec._T_VALID: 0}))
        assert t.ddq1 == 0.0 and not t.ddq1_valid


def test_a_table_that_does_not_fit_the_layout_is_refused() -> None:
    with pytest.raises(ValueError, match="sender"):
        codec.Bounds(heartbeat_t, {"sender": codec.Range(0.0, 1.0)})
    with pytest.raises(ValueError, match="k: 2 numeric ranges for 3 values"):
        codec.Bounds(spine_command_t, {"k": [codec.Range(0.0, 1.0)] * 2})
    with pytest.raises(KeyError, match="nope"):
        codec.Bounds(spine_command_t, {"nope": codec.Range(0.0, 1.0)})


def _fuzz(cls: type, rng: np.random.Generator) -> bytes:
    """A valid message with, now and then, one or two values replaced by NaN, +-inf or far out of range."""
    layout = BOUNDS[cls].layout
    vals = list(layout.unpack(CASES[cls][1]))
    for i, _label, r in BOUNDS[cls].checks:
        if isinstance(vals[i], float):
            lo, hi = max(r.lo, -1e3), min(r.hi, 1e3)
            vals[i] = float(rng.uniform(lo, hi))
    for i in rng.choice(len(vals), size=int(rng.choice([0, 0, 0, 1, 2])), replace=False):
        i = int(i)
        if isinstance(vals[i], float):
            vals[i] = float(rng.choice([math.nan, math.inf, -math.inf, 1e9, -1e9]))
        elif not isinstance(vals[i], str):
            vals[i] = int(rng.integers(-3, 6))
    return layout.pack(vals)


@pytest.mark.parametrize("cls", [motor_feedback_t, motor_command_t], ids=lambda c: c.__name__)
def test_fast_motor_decoders_reject_as_the_checked_ones(cls) -> None:
    rng = np.random.default_rng(12)
    decoders = CASES[cls][2]
    kinds = {"ok": 0, "MessageError": 0}
    for _ in range(1500):
        got = _outcomes(decoders, _fuzz(cls, rng))
        assert got[0] == got[1], got
        kinds[got[0].split(":")[0]] += 1
    assert min(kinds.values()) > 100, kinds


@pytest.mark.parametrize("cls", [heartbeat_t, spine_state_t], ids=lambda c: c.__name__)
def test_a_string_lcm_gen_reads_but_the_layout_does_not_takes_the_reference_path(cls) -> None:
    """An empty string sent as length 0 (no NUL): lcm-gen reads it, `Layout.unpack` refuses it; the decoder
    falls back to lcm-gen's object and checks it with the same bounds."""
    channel, data, decoders = CASES[cls]
    layout = BOUNDS[cls].layout
    a = layout.index("sender" if cls is heartbeat_t else "rejected")[0]
    vals = list(layout.unpack(data))
    vals[a] = ""
    head = 8 + layout.parts[0][0].size  # the string follows the first run of fixed-size fields
    raw = layout.pack(vals)
    crafted = raw[:head] + b"\0\0\0\0" + raw[head + 5:]
    assert layout.unpack(crafted) is None and codec.decode_raw(channel, crafted, cls).seq == vals[1]
    assert _outcomes(decoders, crafted) == ["ok"] * len(decoders)
    m = decoders[0](crafted, channel)
    assert m.seq == vals[1] and (m.sender if cls is heartbeat_t else m.rejected) == ""
    seq = layout.index("seq")[0]
    bad = crafted[:8] + layout.parts[0][0].pack(*[-4 if i == seq else v for i, v in enumerate(vals[:a])]) + \
        crafted[head:]
    want = f"{channel}.seq: -4 is negative" if cls is heartbeat_t else "ok"  # a state's seq has no bound
    assert {o.removeprefix("MessageError: ") for o in _outcomes(decoders, bad)} == {want}
