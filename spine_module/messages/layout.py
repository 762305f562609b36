"""Whole-message binary layouts read from the lcm-gen classes, for the node's 1 kHz codec path.

lcm-gen's Python code encodes and decodes field by field through a BytesIO (a dozen `struct` calls and a
constructor per message). The same bytes are one precompiled `struct.Struct` per run of fixed-size
fields; `Layout` builds it from the generated class's own `__slots__`, `__typenames__` and
`__dimensions__` (nothing hand-copied), so a regenerated type changes the layout with it. Types it
cannot express (nested types, variable-length arrays, byte arrays) raise NotImplementedError and keep
lcm-gen's code. `tests/spine_module/messages/test_messages_layout.py`
checks both directions byte for byte against lcm-gen.
"""

from __future__ import annotations

import math
import struct
from typing import Any

_CODES = {"int8_t": "b", "int16_t": "h", "int32_t": "i", "int64_t": "q", "float": "f", "double": "d",
          "boolean": "b"}
_U32 = struct.Struct(">I")


class Layout:
    """Encode/decode one LCM type. Strings split the message into fixed-size runs of fields."""

    def __init__(self, cls: type) -> None:
        self.cls = cls
        self.fingerprint: bytes = cls._get_packed_fingerprint()
        self.fields: list[tuple[str, int, int, bool, bool]] = []  # name, start, n, is_array, is_bool
        self.parts: list[tuple[struct.Struct | None, int, int]] = []  # (Struct or None for a string, lo, hi)
        fmt, lo, flat = ">", 0, 0
        for name, tn, dims in zip(cls.__slots__, cls.__typenames__, cls.__dimensions__, strict=True):
            if tn == "string" and dims is None:
                if flat > lo:
                    self.parts.append((struct.Struct(fmt), lo, flat))
                self.parts.append((None, flat, flat + 1))
                self.fields.append((name, flat, 1, False, False))
                flat += 1
                fmt, lo = ">", flat
                continue
            if tn not in _CODES or not all(isinstance(d, int) for d in (dims or ())):
                raise NotImplementedError(f"{cls.__name__}.{name}: {tn}{dims or ''} has no fixed layout")
            n = math.prod(dims) if dims else 1
            fmt += f"{n}{_CODES[tn]}" if dims else _CODES[tn]
            self.fields.append((name, flat, n, bool(dims), tn == "boolean"))
            flat += n
        if flat > lo:
            self.parts.append((struct.Struct(fmt), lo, flat))
        self.n_values = flat
        self.fixed = all(st is not None for st, _, _ in self.parts)
        self.size = 8 + sum(st.size for st, _, _ in self.parts if st is not None) if self.fixed else None
        self._struct = self.parts[0][0] if self.fixed and len(self.parts) == 1 else None

    def index(self, name: str) -> tuple[int, int]:
        """(start, count) of field `name` in the flat value tuple that `unpack` returns and `pack` takes."""
        for fname, a, n, _arr, _b in self.fields:
            if fname == name:
                return a, n
        raise KeyError(f"{self.cls.__name__} has no field {name!r}")

    def unpack(self, data: bytes) -> tuple | None:
        """Every value of a message in slot order, arrays flattened (booleans as the raw int8, strings
        decoded as lcm-gen does), or None unless `data` is exactly one well-formed message of this type
        (then lcm-gen's path runs and names the problem)."""
        st = self._struct
        if st is not None:
            if len(data) != self.size or data[:8] != self.fingerprint:
                return None
            return st.unpack_from(data, 8)
        if data[:8] != self.fingerprint:
            return None
        out: list = []
        off, end = 8, len(data)
        for st, _lo, _hi in self.parts:
            if st is None:  # u32 length (with the terminating NUL), bytes, NUL
                if off + 4 > end:
                    return None
                n = _U32.unpack_from(data, off)[0]
                off += 4
                if n < 1 or off + n > end:
                    return None
                out.append(bytes(data[off:off + n - 1]).decode("utf-8", "replace"))  # as lcm-gen: [:-1]
                off += n
            else:
                if off + st.size > end:
                    return None
                out += st.unpack_from(data, off)
                off += st.size
        return tuple(out) if off == end else None

    def decode(self, data: bytes) -> Any | None:
        """The generated message object for `data`, or None unless `data` is exactly one message of this
        type (then lcm-gen's path runs and names the problem)."""
        vals = self.unpack(data)
        if vals is None:
            return None
        m = object.__new__(self.cls)
        for name, a, n, is_array, is_bool in self.fields:
            if is_array:
                v = vals[a:a + n]
                setattr(m, name, list(map(bool, v)) if is_bool else v)
            else:
                setattr(m, name, bool(vals[a]) if is_bool else vals[a])
        return m

    def encode(self, m: Any) -> bytes:
        """The bytes lcm-gen's `m.encode()` writes (arrays must have their declared length)."""
        flat: list = []
        for name, _a, n, is_array, _b in self.fields:
            v = getattr(m, name)
            if is_array:
                if len(v) != n:
                    raise ValueError(f"{self.cls.__name__}.{name}: expected {n} values, got {len(v)}")
                flat += v
            else:
                flat.append(v)
        return self.pack(flat)

    def pack(self, flat: list | tuple) -> bytes:
        """The message's bytes from its values in slot order, arrays flattened (`unpack`'s inverse; the
        caller guarantees each array's length, a wrong total count is a struct.error)."""
        if len(flat) != self.n_values:
            raise struct.error(f"{self.cls.__name__}: {len(flat)} values, the layout has {self.n_values}")
        out = [self.fingerprint]
        for st, lo, hi in self.parts:
            if st is None:
                raw = flat[lo].encode("utf-8")
                out += (_U32.pack(len(raw) + 1), raw, b"\0")
            else:
                out.append(st.pack(*flat[lo:hi]))
        return b"".join(out)


def layouts(classes: tuple[type, ...]) -> dict[type, Layout]:
    """A Layout for every class that has one."""
    out = {}
    for cls in classes:
        try:
            out[cls] = Layout(cls)
        except NotImplementedError:
            pass
    return out
