"""The node's spine states as arrays (one row per state), for saving and for the stiffness estimate."""

from __future__ import annotations

import numpy as np

from spine_module.messages import SpineState

KEYS = ("stamp_s", "seq", "mode", "faults", "q", "dq", "tau_cmd", "tau_est", "x", "dx", "gain_scale",
        "load_cell", "period", "jitter_max", "compute", "feedback_seq")


def states_arrays(states: list[SpineState]) -> dict[str, np.ndarray]:
    return {f"node_{k}": np.array([np.asarray(getattr(s, k), dtype=float) for s in states]) for k in KEYS}
