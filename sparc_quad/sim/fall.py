"""When a bound has fallen: one test, which the Python loops (`bound.python_loop.fall_reason`,
`bound.held_loop`) and the compiled step (`bound.step_kernel`, numba compiles `fall_code`) share."""

from __future__ import annotations

# what each fall_code means (0: standing)
FALL_REASONS = (None, "body touched the ground", "pitch beyond 1 rad", "roll beyond 0.8 rad")


def fall_code(body_contact: bool, q1: float, pitch_front: float, roll: float, slope: float) -> int:
    """0, or the index in FALL_REASONS of the first test this state fails: a body link on the ground, the
    hind (q1, rad) or front body's pitch beyond 1 rad from the ground's slope, the roll beyond 0.8 rad."""
    if body_contact:
        return 1
    if abs(q1 + slope) > 1.0 or abs(pitch_front + slope) > 1.0:
        return 2
    if abs(roll) > 0.8:
        return 3
    return 0
