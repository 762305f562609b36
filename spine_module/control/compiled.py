"""The numba-compiled control step: `spine_module.control.kernel.spine_step` compiled once, cached on disk.

Importing this module needs numba; `load()` returns None where numba is missing or cannot compile, and the
controllers then run the pinocchio path. With `cache=True` a process loads the machine code compiled by an
earlier one (numba's cache next to kernel.py, or NUMBA_CACHE_DIR / the user cache when that is read-only),
so a sweep pays the compile once, not per process.
"""

from __future__ import annotations

from collections.abc import Callable

from numba import njit
from numba.extending import register_jitable

from spine_module.control import kernel

register_jitable(kernel.inertia_apply)  # the step calls it: compiled code may call it, Python still can

# one signature: C-contiguous float64 vectors; anything else raises TypeError and the caller falls back
SIGNATURE = ("int64(float64[::1], float64[::1], float64[::1], float64, float64[::1], float64[::1], "
             "boolean[::1])")

spine_step: Callable[..., int] = njit(SIGNATURE, cache=True, nogil=True,
                                      error_model="numpy")(kernel.spine_step)
