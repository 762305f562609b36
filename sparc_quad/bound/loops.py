"""Which loop runs a bound's steps (`choose_loop`), and why. The loops and their seam: `bound.stepping`."""

from __future__ import annotations

from sparc_quad.bound.held_loop import HeldLoop
from sparc_quad.bound.python_loop import PythonLoop
from sparc_quad.bound.stepping import StepLoop, Steps


def choose_loop(s: Steps, backend: str, held_steps: bool = True, compiled_loop: bool = True) -> StepLoop:
    """The fastest loop that gives `s` the Python loop's numbers; its `why` says why it was picked.

    Held chunks when the world can rewind and the gait and the spine hold their outputs between their
    clocks' calls (`HeldLoop.why_not`); else the compiled loop when the run's per-step code (`backend`) is
    numba and the step is the plain one (`CompiledLoop.why_not`); else the Python loop, which is also the
    one for whatever watches every step (profiling, frames, real time, latency). `held_steps` or
    `compiled_loop` False leaves that loop out (the references they are tested against)."""
    no_held = HeldLoop.why_not(s) if held_steps else "held steps were turned off"
    if no_held is None:
        return HeldLoop("the world rewinds, and the gait and the spine hold their outputs between calls")
    if s.watched():
        return PythonLoop(f"{s.watched()} needs every step in Python")
    if not compiled_loop:
        return PythonLoop(f"{no_held}; the compiled loop was turned off")
    if backend != "numba":
        return PythonLoop(f"{no_held}; the per-step code is {backend}")
    from sparc_quad.bound.compiled_loop import CompiledLoop  # numba runs only (a short run's import cost)

    no_compiled = CompiledLoop.why_not(s.world, s.spine, s.gait)
    if no_compiled is None:
        return CompiledLoop(s.world, s.spine, s.gait)
    return PythonLoop(f"{no_held}; {no_compiled}")
