"""The numba-compiled bound controller step: `gaits.bound_kernel.bound_step` compiled once, cached on disk
(numba's cache next to bound_kernel.py, or NUMBA_CACHE_DIR), so a sweep pays the compile once per machine.
"""

from __future__ import annotations

from collections.abc import Callable

from numba import njit
from numba.extending import register_jitable

from sparc_quad.gaits import bound_kernel

register_jitable(bound_kernel.leg_fk)  # the step calls it: compiled code may call it, Python still can

# C-contiguous float64 vectors: prm, st, inp, out
SIGNATURE = "void(float64[::1], float64[::1], float64[::1], float64[::1])"

bound_step: Callable[..., None] = njit(SIGNATURE, cache=True, nogil=True,
                                       error_model="numpy")(bound_kernel.bound_step)
