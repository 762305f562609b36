"""Which task gains can the node's discrete loop render without chattering? A bound from the law and the rate.

Under eq. 3 each task axis i behaves like a mass m_i = 1 / (J M^-1 J^T)_ii driven by -K_i e - D_i de/dt, the
torque held for one control period T. With a = D T / m and b = K T^2 / m, one axis sampled that way
(semi-implicit Euler: v' = v - (T/m)(K e + D v), e' = e + T v') has the characteristic polynomial

    z^2 - (2 - a - b) z + (1 - a)

and by Jury's test is stable iff b > 0, a < 2 and 2a + b < 4. At 2a + b = 4 a root reaches z = -1: the
torque flips sign every tick at full amplitude, which is the chatter seen (d_theta >= 5 N*m*s/rad at
1 kHz, issue 31). The smallest m_i over the joint ranges gives the worst case: the largest mobility
(J M^-1 J^T)_ii, `MOBILITY_MAX` (1/kg, 1/kg, 1/(kg*m^2)), measured on 6000 random poses of the SPARC
spine's joint ranges with the reflected rotor inertia (6.17, 6.12, 739) and rounded up by 5 %
(`tests/spine_module/control/test_gain_limits.py` recomputes it). The axes share the non-diagonal task
inertia, so the node asks the sum over the axes to stay within `STABILITY_BUDGET` = 3.2, 80 % of the one-axis
bound 4:

    sum_i MOBILITY_MAX_i (2 D_i T + K_i T^2) <= 3.2

Each axis alone then has 2a + b <= 3.2 and a <= 1.6; the coupled three-axis loop is checked numerically in
the test (spectral radius < 1 on random poses and gains at the budget). At 1 kHz, one axis alone may take
up to d_x 246 N*s/m, d_z 246 N*s/m, d_theta 2.05 N*m*s/rad (K = 0), or k_theta 4100 N*m/rad (D = 0); at the
node's lowest rate, 100 Hz, a tenth of the damping and a hundredth of the stiffness.
"""

from __future__ import annotations

MOBILITY_MAX = (6.5, 6.5, 780.0)  # max (J M^-1 J^T)_ii over the joint ranges: 1/kg, 1/kg, 1/(kg*m^2)
STABILITY_BUDGET = 3.2  # of the Jury bound 2a + b < 4 for one axis


def stability_use(k, d, period_s: float) -> float:
    """sum_i MOBILITY_MAX_i (2 D_i T + K_i T^2): at most STABILITY_BUDGET for a loop that does not chatter."""
    t = period_s
    return sum(m * (2.0 * float(di) * t + float(ki) * t * t)
               for m, ki, di in zip(MOBILITY_MAX, k, d, strict=True))


def unstable_gains(k, d, rate_hz: float) -> str | None:
    """Why these gains would make the loop at `rate_hz` chatter (naming each axis's share), or None."""
    use = stability_use(k, d, 1.0 / rate_hz)
    if use <= STABILITY_BUDGET:
        return None
    t = 1.0 / rate_hz
    parts = ", ".join(f"{name} {m * (2.0 * float(di) * t + float(ki) * t * t):.3g}"
                      for name, m, ki, di in zip(("x", "z", "theta"), MOBILITY_MAX, k, d, strict=True))
    return (f"gains not renderable at {rate_hz:g} Hz: sum of (2 D T + K T^2) / m_min over the axes is "
            f"{use:.3g} ({parts}), above {STABILITY_BUDGET:g} (discrete-time stability: "
            "spine_module/control/gain_limits.py)")


__all__ = ["MOBILITY_MAX", "STABILITY_BUDGET", "stability_use", "unstable_gains"]
