"""Which implementation a bound's per-step code runs: the compiled (numba) spine step and bound controller,
or the Python/pinocchio reference paths. The choice is a pure function of the run's configuration, never
of what this process loaded before, so a study's trial does not depend on the trials its worker ran first.

The compiled paths equal the reference to round-off (tests/sparc_quad/sim/test_bound_backend.py), but a
bound is chaotic over seconds of contacts, so a long run's trajectory is the same bound, not the same bits.
"""

from __future__ import annotations

import importlib.util
import signal

BACKENDS = ("auto", "numba", "python")
# "auto" compiles only runs at least this long (simulated s). Measured on this project's 2-core machine
# (docs/performance.md): loading numba and both cached kernels costs ~0.7-0.8 s of CPU per process; the
# kernels save ~0.1 s of CPU per simulated second (spine ~38 us + gait ~55 us per 1 kHz step).
NUMBA_PAYBACK_SIM_S = 8.0


def resolve_backend(backend: str, duration_s: float) -> str:
    """"numba" or "python" for a run of `duration_s` simulated seconds: "auto" -> "numba" when the run is
    long enough to pay for loading the kernels and numba is installed."""
    if backend not in BACKENDS:
        raise ValueError(f"backend must be one of {', '.join(BACKENDS)}, got {backend!r}")
    if backend != "auto":
        return backend
    if duration_s >= NUMBA_PAYBACK_SIM_S and importlib.util.find_spec("numba") is not None:
        return "numba"
    return "python"


def load_compiled() -> None:
    """Import numba and the cached kernels with SIGINT and SIGTERM blocked in this thread, then unblock
    them: a signal that arrives meanwhile is delivered after the load, and the thread the load starts
    inherits the block, so these signals always reach Python's handler on the main thread. A kernel that
    cannot load is left to the callers' own checks."""
    held = {signal.SIGINT, signal.SIGTERM}
    old = signal.pthread_sigmask(signal.SIG_BLOCK, held) if hasattr(signal, "pthread_sigmask") else None
    try:
        import spine_module.control.compiled  # noqa: F401
    except Exception:  # ImportError or a numba failure: the controllers name it when they need it
        pass
    finally:
        if old is not None:
            signal.pthread_sigmask(signal.SIG_SETMASK, old)
