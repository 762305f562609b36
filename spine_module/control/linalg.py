"""A 3x3 linear solve for the control step, in plain floats.

The robot-side install has numpy but not scipy, and numpy.linalg.solve spends ~10 us of call overhead on a
3x3 (LAPACK's gesv through scipy: ~2 us). Cramer's rule on Python floats takes ~2 us and is exact enough
for the well-conditioned JJᵀ + λ²I it is used on (checked against numpy.linalg.solve in the tests).
"""

from __future__ import annotations

import numpy as np


def solve3(a: np.ndarray, b: np.ndarray, out: np.ndarray) -> np.ndarray:
    """x with a @ x = b for a 3x3 `a` (written into `out`, returned). A singular `a` gives inf/nan."""
    (a00, a01, a02), (a10, a11, a12), (a20, a21, a22) = a.tolist()
    b0, b1, b2 = b.tolist()
    c00 = a11 * a22 - a12 * a21
    c01 = a12 * a20 - a10 * a22
    c02 = a10 * a21 - a11 * a20
    det = a00 * c00 + a01 * c01 + a02 * c02
    out[0] = (b0 * c00 + a01 * (a12 * b2 - b1 * a22) + a02 * (b1 * a21 - a11 * b2)) / det
    out[1] = (a00 * (b1 * a22 - a12 * b2) + b0 * c01 + a02 * (a10 * b2 - b1 * a20)) / det
    out[2] = (a00 * (a11 * b2 - b1 * a21) + a01 * (b1 * a20 - a10 * b2) + b0 * c02) / det
    return out
