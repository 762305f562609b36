"""Strict JSON: what the tools write parses with a reader that refuses NaN and Infinity."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from sparc_quad.jsonfmt import json_text, jsonable


def _strict(text: str):
    def refuse(token: str):
        raise ValueError(f"non-standard JSON token {token}")

    return json.loads(text, parse_constant=refuse)


def test_undefined_numbers_become_null_everywhere_in_the_tree() -> None:
    obj = {"a": math.nan, "b": [1.0, math.inf, -math.inf],
           "c": {"d": np.float64("nan"), 3: np.array([1.5, np.nan])}, "e": (np.int64(2), True, None, "x")}
    out = _strict(json_text(obj, indent=2))
    assert out == {"a": None, "b": [1.0, None, None], "c": {"d": None, "3": [1.5, None]},
                   "e": [2, True, None, "x"]}


def test_finite_numbers_are_kept_exactly() -> None:
    x = [0.1 + 0.2, 1e-300, -2.5e300, 7]
    assert _strict(json_text(x)) == x
    assert jsonable(np.float64(0.1)) == 0.1 and type(jsonable(np.float64(0.1))) is float


def test_other_types_need_a_default() -> None:
    with pytest.raises(TypeError):
        json_text({"raw": b"\x00"})
    assert _strict(json_text({"raw": b"\x00"}, default=str)) == {"raw": "b'\\x00'"}
