"""Gait A's joint PD step at a control call, over plain float64 arrays: what `SineBoundController._pd`
computes while running, written once so numba can compile it (`sine_compiled`). Every expression is the
Python path's, in its order (`_foot_xz`, `planar_leg_ik`, the PD and the clip with Python's min/max), so the
compiled step gives the same doubles: the open-loop bound's 20 s outcome flips on differences far smaller
than a round-off (docs/results/2026-12-02-base-motion.md).

legs (4, 8): per leg HL, HR, FL, FR: phase offset (rad), 1.0 for a right leg (its stride scale), HAA, HFE,
KFE slots in jq / jdq, thigh (m), shank (m), knee sign. gains (9): kp (N*m/rad), kd (N*m*s/rad), HAA kp, HAA
kd, torque limit (N*m), the stride's sign in the robot's x, step length L (m), hip depth (m), step height
H (m). out (4, 3): HAA, HFE, KFE torques (N*m) per leg.
"""

from __future__ import annotations

import math


def _min(a: float, b: float) -> float:  # Python's min(a, b): the first unless the second is smaller
    return b if b < a else a


def _max(a: float, b: float) -> float:  # Python's max(a, b): the first unless the second is larger
    return b if b > a else a


def pd_step(phase, amp, scale_l, scale_r, jq, jdq, legs, gains, out) -> None:
    kp, kd, haa_kp, haa_kd, lim = gains[0], gains[1], gains[2], gains[3], gains[4]
    x_sign, step_l, hip_depth, step_h = gains[5], gains[6], gains[7], gains[8]
    for n in range(4):
        leg = legs[n]
        ph = phase + leg[0]
        scale = scale_r if leg[1] != 0.0 else scale_l
        i_haa, i_hfe, i_kfe = int(leg[2]), int(leg[3]), int(leg[4])
        l1, l2, sgn = leg[5], leg[6], leg[7]
        # _foot_xz
        s = math.sin(ph)
        x = x_sign * amp * step_l * scale * math.cos(ph)
        z = -hip_depth + (amp * step_h * s if s > 0 else 0.0)
        # planar_leg_ik
        r2 = x * x + z * z
        ck = _max(-1.0, _min(1.0, (r2 - l1 * l1 - l2 * l2) / (2 * l1 * l2)))
        k = sgn * math.acos(ck)
        a = l1 + l2 * math.cos(k)
        b = l2 * math.sin(k)
        h = math.atan2(-x, -z) - math.atan2(b, a)
        # the joint PD, clipped
        tau_haa = -haa_kp * jq[i_haa] - haa_kd * jdq[i_haa]
        tau_h = kp * (h - jq[i_hfe]) - kd * jdq[i_hfe]
        tau_k = kp * (k - jq[i_kfe]) - kd * jdq[i_kfe]
        out[n, 0] = _max(-lim, _min(lim, tau_haa))
        out[n, 1] = _max(-lim, _min(lim, tau_h))
        out[n, 2] = _max(-lim, _min(lim, tau_k))
