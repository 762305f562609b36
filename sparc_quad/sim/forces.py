"""External pushes on the bench spine's end effector: the project's one `ForceLaw` type and the paper's
push-pull (Section IV-A). Here, below the rig, the robot side and the bench experiments that all use it."""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

# external force along x (N) as a function of (time s, true task pose, true task velocity)
ForceLaw = Callable[[float, np.ndarray, np.ndarray], float]


def push_pull(amplitude_n: float, period_s: float) -> ForceLaw:
    """amplitude_n sin(2 pi t / period_s), N."""
    def force(t: float, x: np.ndarray, dx: np.ndarray) -> float:
        return amplitude_n * math.sin(2 * math.pi * t / period_s)
    return force
