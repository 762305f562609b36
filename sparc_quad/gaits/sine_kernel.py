"""Gait A's joint PD step at a control call, over plain float64 arrays: what `SineBoundController._pd`
computes while running, in a form numba can compile (`sine_compiled`). It calls what the Python path
calls, `foot_xz` (here) and `planar_leg_ik` (compiled with it), and clips with Python's min/max
semantics, so the compiled step gives the same doubles for finite states: the open-loop bound's 20 s
outcome flips on differences far smaller than a round-off (notebook/2026-12-02-base-motion.md).

legs (4, 8): per leg HL, HR, FL, FR: phase offset (rad), 1.0 for a right leg (its stride scale), HAA, HFE,
KFE slots in jq / jdq, thigh (m), shank (m), knee sign. gains (9): kp (N*m/rad), kd (N*m*s/rad), HAA kp, HAA
kd, torque limit (N*m), the stride's sign in the robot's x, step length L (m), hip depth (m), step height
H (m). out (4, 3): HAA, HFE, KFE torques (N*m) per leg.
"""

from __future__ import annotations

import math

from sparc_quad.sim.quadruped_world import planar_leg_ik


def foot_xz(ph: float, scale: float, amp: float, x_sign: float, step_length_m: float, hip_depth_m: float,
            step_height_m: float) -> tuple[float, float]:
    """Foot (x, z) m relative to the hip in the body frame at leg phase `ph` (rad): x = L cos(ph) scaled by
    the side's stride scale and the stride's sign, z the hip depth plus the raised half of H sin(ph). The
    one formula (the Python gait and the compiled step below both call it)."""
    s = math.sin(ph)
    x = x_sign * amp * step_length_m * scale * math.cos(ph)
    z = -hip_depth_m + (amp * step_height_m * s if s > 0 else 0.0)
    return x, z


def clip(v: float, lim: float) -> float:
    """Python's max(-lim, min(lim, v)), written out: numba's builtins differ on NaN."""
    m = v if v < lim else lim  # min(lim, v): lim unless v is smaller (NaN: lim)
    return m if m > -lim else -lim  # max(-lim, m): -lim unless m is larger


def pd_step(phase, amp, scale_l, scale_r, jq, jdq, legs, gains, out) -> None:
    kp, kd, haa_kp, haa_kd, lim = gains[0], gains[1], gains[2], gains[3], gains[4]
    x_sign, step_l, hip_depth, step_h = gains[5], gains[6], gains[7], gains[8]
    for n in range(4):
        leg = legs[n]
        scale = scale_r if leg[1] != 0.0 else scale_l
        i_haa, i_hfe, i_kfe = int(leg[2]), int(leg[3]), int(leg[4])
        x, z = foot_xz(phase + leg[0], scale, amp, x_sign, step_l, hip_depth, step_h)
        h, k = planar_leg_ik(leg[5], leg[6], leg[7], x, z)
        out[n, 0] = clip(-haa_kp * jq[i_haa] - haa_kd * jdq[i_haa], lim)
        out[n, 1] = clip(kp * (h - jq[i_hfe]) - kd * jdq[i_hfe], lim)
        out[n, 2] = clip(kp * (k - jq[i_kfe]) - kd * jdq[i_kfe], lim)
