"""Fuzzing every interface's decoder. A decoder returns a value or raises its own
error type naming the problem (MessageError for LCM, FrameError for CAN), never anything else; the
emulator answers anything without raising. Short runs in the default suite, long ones slow-marked."""

from __future__ import annotations

import math
import struct

import can
import numpy as np
import pytest

from spine_module.buses.cybergear import protocol as P
from spine_module.messages import (
    Heartbeat,
    MessageError,
    MotorCommand,
    MotorFeedback,
    SpineCommand,
    SpineState,
    TorsoState,
    channels,
    codec,
)

_VALID = {
    channels.TORSO_STATE: codec.encode_torso(TorsoState(seq=1)),
    channels.SPINE_COMMAND: codec.encode_command(SpineCommand(seq=2)),
    channels.SPINE_STATE: codec.encode_state(SpineState(seq=3)),
    channels.MOTOR_COMMAND: codec.encode_motor_command(MotorCommand.zero(), feedback_seq=4),
    channels.MOTOR_FEEDBACK: codec.encode_motor_feedback(MotorFeedback(q=np.zeros(3), dq=np.zeros(3),
                                                                       tau=np.zeros(3))),
    channels.HEARTBEAT_NODE: codec.encode_heartbeat(Heartbeat("node", False, 0, 0.0, 5)),
    channels.HEARTBEAT_ROBOT: codec.encode_heartbeat(Heartbeat("robot", False, 0, 0.0, 6)),
}
_SPECIAL = [struct.pack(">d", v) for v in (math.nan, math.inf, -math.inf, 1e300, -0.0)] + \
    [struct.pack(">i", v) for v in (-1, 2**31 - 1, 99, 7)]


def _mutate(rng: np.random.Generator, good: bytes) -> bytes:
    b = bytearray(good)
    kind = rng.integers(6)
    if kind == 0:  # flip bytes after the fingerprint
        for _ in range(rng.integers(1, 4)):
            b[rng.integers(8, len(b))] = rng.integers(256)
    elif kind == 1:  # truncate
        b = b[:rng.integers(0, len(b))]
    elif kind == 2:  # extend
        b += bytes(rng.integers(0, 256, rng.integers(1, 16)).astype(np.uint8))
    elif kind == 3:  # a special value (NaN, inf, huge, out-of-range enum) somewhere
        sp = _SPECIAL[rng.integers(len(_SPECIAL))]
        at = rng.integers(8, max(9, len(b) - len(sp)))
        b[at:at + len(sp)] = sp
    elif kind == 4:  # random bytes with a valid fingerprint
        b = b[:8] + bytes(rng.integers(0, 256, rng.integers(0, 2 * len(good))).astype(np.uint8))
    else:  # pure garbage
        b = bytes(rng.integers(0, 256, rng.integers(0, 64)).astype(np.uint8))
    return bytes(b)


def _fuzz_lcm(n: int, seed: int) -> dict[str, int]:
    rng = np.random.default_rng(seed)
    outcome = {"accepted": 0, "rejected": 0}
    names = list(_VALID)
    for _ in range(n):
        ch = names[rng.integers(len(names))]
        data = _mutate(rng, _VALID[ch])
        try:
            codec.decode(ch, data)
        except MessageError as e:
            assert str(e).startswith(ch), str(e)
            outcome["rejected"] += 1
        else:
            outcome["accepted"] += 1
    return outcome


def _fuzz_can(n: int, seed: int) -> dict[str, int]:
    from sparc_quad.sim.cybergear_emulator import CyberGearEmulator

    class _NullBus(can.BusABC):
        def __init__(self) -> None:
            super().__init__(channel="null")
            self.sent: list[can.Message] = []

        def send(self, msg, timeout=None):
            self.sent.append(msg)

        def _recv_internal(self, timeout):
            return None, False

    rng = np.random.default_rng(seed)
    bus = _NullBus()
    emu = CyberGearEmulator(bus, (1, 2, 3), start=False)
    emu.keep_log = False
    outcome = {"decoded": 0, "rejected": 0}
    types = [0, 1, 2, 3, 4, 5, 6, 7, 17, 18, 21, 22, 31]
    for _ in range(n):
        if rng.random() < 0.7:
            arb = P.make_id(int(rng.choice(types)), int(rng.integers(0, 0x10000)),
                            int(rng.choice([0, 1, 2, 3, 0x7F, 0xFD, 0xFE, int(rng.integers(256))])))
        else:
            arb = int(rng.integers(0, P.ID_MASK_29 + 1))
        ext = rng.random() < 0.95
        data = bytes(rng.integers(0, 256, rng.integers(0, 9)).astype(np.uint8))
        if rng.random() < 0.3 and len(data) >= 2:  # a known parameter index, to reach the value decoders
            data = struct.pack("<H", P.PARAMS[rng.integers(len(P.PARAMS))].index) + data[2:]
        msg = can.Message(arbitration_id=arb if ext else arb & 0x7FF, data=data, is_extended_id=ext,
                          check=False)
        for decode in (lambda m: P.decode_from_motor(m, 0xFD, {1, 2, 3}),
                       lambda m: P.decode_to_motor(m, {1, 2, 3})):
            try:
                decode(msg)
                outcome["decoded"] += 1
            except P.FrameError as e:
                assert e.reason
                outcome["rejected"] += 1
        bus.sent.clear()
        emu.handle(msg)
        for reply in bus.sent:
            assert isinstance(P.decode_from_motor(reply), P.Frame)
    bus.shutdown()
    return outcome


def test_fuzz_lcm_decoders_short():
    out = _fuzz_lcm(5_000, seed=1)
    print("LCM fuzz 5k:", out)
    assert out["rejected"] > 1_000 and out["accepted"] > 100, out  # both paths really exercised


def test_fuzz_can_decoders_and_emulator_short():
    out = _fuzz_can(5_000, seed=2)
    print("CAN fuzz 5k:", out)
    assert out["rejected"] > 1_000 and out["decoded"] > 100, out


@pytest.mark.slow
def test_fuzz_lcm_decoders_long():
    out = _fuzz_lcm(100_000, seed=11)
    print("LCM fuzz 100k:", out)
    assert out["rejected"] > 20_000 and out["accepted"] > 2_000, out  # both paths, at the short run's share


@pytest.mark.slow
def test_fuzz_can_decoders_and_emulator_long():
    out = _fuzz_can(200_000, seed=12)
    print("CAN fuzz 200k:", out)
    assert out["rejected"] > 40_000 and out["decoded"] > 4_000, out
