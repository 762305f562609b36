"""The compiled control step of a bound: `bound.step_kernel.control_step` compiled once, cached on disk
(numba's cache next to step_kernel.py, or NUMBA_CACHE_DIR), with the spine kernel, the bound controller and
the fall test it calls compiled into it."""

from __future__ import annotations

from collections.abc import Callable

from numba import njit
from numba.extending import register_jitable

import sparc_quad.gaits.bound_compiled  # noqa: F401  (makes bound_kernel.leg_fk callable from compiled code)
import spine_module.control.compiled  # noqa: F401  (likewise kernel.inertia_apply)
from sparc_quad.bound import step_kernel
from sparc_quad.gaits import bound_kernel
from sparc_quad.sim import fall
from spine_module.control import kernel

for _fn in (kernel.spine_step, bound_kernel.bound_step, fall.fall_code, step_kernel.estimate,
            step_kernel.limit_torque3, step_kernel._limit_damping, step_kernel._clamp):
    register_jitable(_fn)  # compiled code may call them; Python still can

# sprm, res, sat (bool), gprm, gst, ws, cols (int64), noise (rows of 3), k, log (2-D), i
SIGNATURE = ("int64(float64[::1], float64[::1], boolean[::1], float64[::1], float64[::1], float64[::1], "
             "int64[::1], float64[:, ::1], int64, float64[:, ::1], int64)")

control_step: Callable[..., int] = njit(SIGNATURE, cache=True, nogil=True,
                                        error_model="numpy")(step_kernel.control_step)
