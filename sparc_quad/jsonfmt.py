"""Strict JSON for every file and line the tools write: an undefined number (NaN, inf) is `null`.

Python's json writes NaN and Infinity tokens, which RFC 8259 does not allow and jq, JavaScript and most
JSON readers refuse; a metric that is undefined for a run (the stride frequency of a robot that never
strode) must still leave a readable metrics.json.
"""

from __future__ import annotations

import json
import math


def jsonable(x):
    """NaN and inf become None, numpy scalars and arrays plain numbers and lists, keys strings."""
    if isinstance(x, dict):
        return {str(k): jsonable(v) for k, v in x.items()}
    if isinstance(x, list | tuple):
        return [jsonable(v) for v in x]
    if hasattr(x, "tolist"):  # numpy scalars and arrays
        return jsonable(x.tolist())
    if isinstance(x, float) and not math.isfinite(x):
        return None
    return x


def json_text(obj, indent: int | None = None, default=None) -> str:
    """`obj` as strict JSON; `default` as json.dumps's, for values of other types."""
    return json.dumps(jsonable(obj), indent=indent, allow_nan=False, default=default)
