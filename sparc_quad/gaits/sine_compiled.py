"""`gaits.sine_kernel.pd_step` compiled once and cached on disk (numba's cache next to sine_kernel.py, or
NUMBA_CACHE_DIR), like `bound_compiled`."""

from __future__ import annotations

from collections.abc import Callable

from numba import njit
from numba.extending import register_jitable

from sparc_quad.gaits import sine_kernel
from sparc_quad.sim import quadruped_world

# what the step calls, compiled with it (Python still calls the originals)
register_jitable(sine_kernel.clip)
register_jitable(sine_kernel.foot_xz)
register_jitable(quadruped_world.planar_leg_ik)

# phase, amp, scale_l, scale_r, jq, jdq, legs, gains, out
SIGNATURE = ("void(float64, float64, float64, float64, float64[::1], float64[::1], float64[:, ::1], "
             "float64[::1], float64[:, ::1])")

pd_step: Callable[..., None] = njit(SIGNATURE, cache=True, nogil=True,
                                    error_model="numpy")(sine_kernel.pd_step)
