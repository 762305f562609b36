"""The whole-message struct layouts (messages/layout.py) write and read exactly lcm-gen's bytes."""

from __future__ import annotations

import numpy as np
import pytest

from spine_module.messages import codec
from spine_module.messages.layout import Layout, layouts

LAYOUTS = layouts(codec.LCM_TYPES)


def _random(cls: type, rng: np.random.Generator):
    m = cls()
    for name, tn, dims in zip(cls.__slots__, cls.__typenames__, cls.__dimensions__, strict=True):
        n = dims[0] if dims else None

        def one(tn=tn):
            if tn == "double":
                return float(rng.normal(0.0, 100.0))
            if tn == "boolean":
                return bool(rng.integers(0, 2))
            if tn == "string":
                return "".join(rng.choice(list("abcé xyz_.:[]0")) for _ in range(rng.integers(0, 40)))
            bits = {"int8_t": 7, "int16_t": 15, "int32_t": 31, "int64_t": 62}[tn]
            return int(rng.integers(-(2**bits), 2**bits))

        setattr(m, name, tuple(one() for _ in range(n)) if n else one())
    return m


def test_every_sparc_type_has_a_layout() -> None:
    assert set(LAYOUTS) == set(codec.LCM_TYPES)
    assert all(LAYOUTS[c].fixed for c in (codec.torso_state_t, codec.spine_command_t, codec.motor_command_t,
                                          codec.motor_feedback_t))


@pytest.mark.parametrize("cls", codec.LCM_TYPES, ids=lambda c: c.__name__)
def test_layout_bytes_equal_lcm_gen(cls: type) -> None:
    rng = np.random.default_rng(3)
    layout = LAYOUTS[cls]
    for _ in range(300):
        m = _random(cls, rng)
        data = m.encode()
        assert layout.encode(m) == data
        # fixed-size and string-bearing types alike
        back = layout.decode(data)
        ref = cls.decode(data)
        for name in cls.__slots__:
            assert getattr(back, name) == getattr(ref, name), name
            assert type(getattr(back, name)) is type(getattr(ref, name)), name
        assert layout.decode(data[:-1]) is None  # anything but one exact message: lcm-gen's path
        assert layout.decode(data + b"\0") is None
        assert layout.decode(b"\0" * len(data)) is None


def test_strings_decode_as_lcm_gen_does() -> None:
    """Odd strings (invalid UTF-8, a last byte that is not NUL) come out as lcm-gen reads them; a length
    that does not fit (or 0) is left to lcm-gen's path."""
    cls = codec.heartbeat_t
    layout = LAYOUTS[cls]
    m = cls()
    m.sender = "robot"
    data = bytearray(m.encode())
    data[8 + 16 + 4] = 0xFF  # invalid UTF-8 first byte
    data[8 + 16 + 4 + 5] = ord("x")  # the terminating NUL
    assert layout.decode(bytes(data)).sender == cls.decode(bytes(data)).sender == "\ufffdobot"
    for n in (0, 7, 1000):
        bad = bytearray(data)
        bad[8 + 16:8 + 20] = n.to_bytes(4, "big")
        assert layout.unpack(bytes(bad)) is None


def test_layout_refuses_what_it_cannot_express() -> None:
    class Nested:
        __slots__ = ["a"]
        __typenames__ = ("sparc.other_t",)
        __dimensions__ = (None,)

        @staticmethod
        def _get_packed_fingerprint() -> bytes:
            return b"\0" * 8

    with pytest.raises(NotImplementedError, match="no fixed layout"):
        Layout(Nested)


def test_short_array_is_an_error_not_a_truncated_message() -> None:
    m = _random(codec.spine_command_t, np.random.default_rng(0))
    m.x_d = (1.0, 2.0)
    with pytest.raises(ValueError, match="x_d: expected 3 values"):
        LAYOUTS[codec.spine_command_t].encode(m)
