"""The virtual-leg bound controller (`gaits.bound.BoundController`) as one function over flat float arrays,
so that numba can compile it (`gaits.bound_compiled`); `gaits.bound_fast.CompiledBoundController` is the
drop-in wrapper.

Why: the Python controller costs ~60 us per 1 kHz step in dicts, tuples and attribute look-ups around
~1 us of arithmetic, about as much as the physics step it drives. The arithmetic here is the reference
controller's, operation for operation; `BoundController` stays the reference (tests run both on the same
states and compare the torques). Nothing is a copied constant: `pack` reads the gains from `BoundParams`
and the geometry from the world and `spine_module.params`. This module imports neither numba nor pybullet;
plain Python can run `bound_step` too (slowly).

Arrays (float64): `prm` (P_* slots, then LEG_STRIDE per leg HL, HR, FL, FR: thigh, shank, side, and the
places of HAA, HFE, KFE in the world's joint-state lists), `st` (S_* controller state), `inp` (I_* base
state, then the world's jq and jdq lists), `out` (12 leg torques, N*m, legs in LEGS order).
"""

from __future__ import annotations

import math

import numpy as np

from spine_module import params as P

LEGS = ("HL", "HR", "FL", "FR")

# prm slots
(P_START, P_SPEED, P_ACCEL, P_FREQ, P_PHASE_OFF, P_LAT, P_ROLL_KP, P_ROLL_KD, P_YAW_KP, P_YAW_KD, P_PITCH_KP,
 P_PITCH_KD, P_KI, P_INT_MAX, P_HEIGHT, P_H_KP, P_H_KD, P_SPEED_GAIN, P_FRIC, P_BODY_KP, P_BODY_KD, P_RAIBERT,
 P_STEP_H, P_SW_KP, P_SW_KD, P_AB_KP, P_AB_KD, P_DUTY_FIXED, P_DUTY, P_DUTY_SLOW, P_DUTY_FAST, P_DUTY_LO,
 P_DUTY_HI, P_DT, P_SLOPE, P_MASS, P_SHARE_HIND, P_SHARE_FRONT, P_TAU_LIM, P_LX_HIND, P_LX_FRONT, P_LINK0,
 P_LINK1, P_LINK2, P_G, P_A_SPEED, P_A_HIP, P_NJ, P_YAW_D_MAX, P_TD_MAX, P_ARM_MIN, P_TD_SINK,
 P_STAND_D) = range(53)
P_LEGS = 53
# per-leg slots from P_LEGS + LEG_STRIDE * leg: thigh m, shank m, side (+1 left), and the places of HAA, HFE,
# KFE in jq/jdq
(L_THIGH, L_SHANK, L_SIDE, L_HAA, L_HFE, L_KFE) = range(6)
LEG_STRIDE = 6
# st slots
(S_V_TARGET, S_V_INT, S_PHASE, S_DUTY, S_SPEED_Y, S_HIPVX_H, S_HIPVX_F, S_HIPVZ_H, S_HIPVZ_F,
 S_PREV_SET_H, S_PREV_SET_F, S_PREV_HX_H, S_PREV_HZ_H, S_PREV_HX_F, S_PREV_HZ_F, S_STANCE_H, S_STANCE_F,
 S_PITCH) = range(18)
S_LIFTOFF = 18  # per leg: set flag, x, z
STATE_SIZE = S_LIFTOFF + 3 * 4
# inp slots
(I_T, I_X, I_Y, I_Z, I_Q1, I_DQ1, I_ROLL, I_YAW, I_WX, I_WZ, I_QS0, I_QS1, I_QS2, I_DQS0, I_DQS1,
 I_DQS2) = range(16)
I_JQ = 16  # then nj joint angles, then nj joint rates


def leg_fk(l1: float, l2: float, h: float, k: float, dh: float, dk: float):
    """Planar foot position and velocity relative to the hip in the body frame (x fwd, z up) and the
    Jacobian: (x, z, vx, vz, j11, j12, j21, j22). Shared by the reference controller and this kernel
    (`gaits.bound_compiled` makes it callable from compiled code)."""
    s1, c1 = math.sin(h), math.cos(h)
    s12, c12 = math.sin(h + k), math.cos(h + k)
    x = -l1 * s1 - l2 * s12
    z = -l1 * c1 - l2 * c12
    j11, j12 = -l1 * c1 - l2 * c12, -l2 * c12
    j21, j22 = l1 * s1 + l2 * s12, l2 * s12
    return x, z, j11 * dh + j12 * dk, j21 * dh + j22 * dk, j11, j12, j21, j22


def bound_step(prm: np.ndarray, st: np.ndarray, inp: np.ndarray, out: np.ndarray) -> None:
    """One step of `BoundController.step`: updates `st` and writes the 12 leg torques into `out`."""
    g = prm[P_G]
    dt = prm[P_DT]
    slope = prm[P_SLOPE]
    tan_s = math.tan(slope)
    t = inp[I_T]
    running = t >= prm[P_START]
    if running:
        speed = prm[P_SPEED]
        if speed >= 0:
            st[S_V_TARGET] = min(speed, st[S_V_TARGET] + prm[P_ACCEL] * dt)
        else:
            st[S_V_TARGET] = max(speed, st[S_V_TARGET] - prm[P_ACCEL] * dt)
        st[S_PHASE] = ((t - prm[P_START]) * prm[P_FREQ]) % 1.0
    v_target = st[S_V_TARGET]
    phase = st[S_PHASE]
    if prm[P_DUTY_FIXED] > 0.5:
        duty = prm[P_DUTY]
    else:
        lo, hi = prm[P_DUTY_LO], prm[P_DUTY_HI]
        f = min(1.0, max(0.0, (abs(v_target) - lo) / (hi - lo))) if hi > lo else 1.0
        duty = prm[P_DUTY_SLOW] + f * (prm[P_DUTY_FAST] - prm[P_DUTY_SLOW])
    st[S_DUTY] = duty
    period = 1.0 / prm[P_FREQ]
    t_stance = duty * period
    roll, yaw = inp[I_ROLL], inp[I_YAW]
    wx, wz = inp[I_WX], inp[I_WZ]
    yaw_d = -prm[P_LAT] * inp[I_Y]
    yaw_d = max(-prm[P_YAW_D_MAX], min(prm[P_YAW_D_MAX], yaw_d))
    d_roll = prm[P_ROLL_KP] * roll + prm[P_ROLL_KD] * wx
    d_yaw = prm[P_YAW_KP] * (yaw - yaw_d) + prm[P_YAW_KD] * wz
    a_hip = prm[P_A_HIP]
    # the pairs' body frames: hind = the base; front = after the three spine links
    kin = np.empty((2, 6))
    body = np.empty((2, 2))
    for pair in range(2):
        bx, bz, phi, dphi = inp[I_X], inp[I_Z], inp[I_Q1], inp[I_DQ1]
        if pair == 1:
            for j in range(3):
                length = prm[P_LINK0 + j]
                bx += length * math.cos(phi)
                bz -= length * math.sin(phi)
                phi += inp[I_QS0 + j]
                dphi += inp[I_DQS0 + j]
        c, s = math.cos(phi), math.sin(phi)
        hip_bx = prm[P_LX_HIND + pair]
        hx = bx + c * hip_bx
        hz = bz - s * hip_bx
        if st[S_PREV_SET_H + pair] > 0.5:
            px, pz = st[S_PREV_HX_H + 2 * pair], st[S_PREV_HZ_H + 2 * pair]
        else:
            px, pz = hx, hz
        st[S_HIPVX_H + pair] += a_hip * ((hx - px) / dt - st[S_HIPVX_H + pair])
        st[S_HIPVZ_H + pair] += a_hip * ((hz - pz) / dt - st[S_HIPVZ_H + pair])
        st[S_PREV_SET_H + pair] = 1.0
        st[S_PREV_HX_H + 2 * pair] = hx
        st[S_PREV_HZ_H + 2 * pair] = hz
        kin[pair, 0], kin[pair, 1], kin[pair, 2], kin[pair, 3] = c, s, hx, hz
        kin[pair, 4], kin[pair, 5] = st[S_HIPVX_H + pair], st[S_HIPVZ_H + pair]
        body[pair, 0], body[pair, 1] = phi, dphi
    hx_h, hz_h, vx_h, vz_h = kin[0, 2], kin[0, 3], kin[0, 4], kin[0, 5]
    hx_f, hz_f, vx_f, vz_f = kin[1, 2], kin[1, 3], kin[1, 4], kin[1, 5]
    span = math.hypot(hx_f - hx_h, hz_f - hz_h)
    pitch = -math.atan2(hz_f - hz_h, hx_f - hx_h)
    dpitch = -((vz_f - vz_h) * (hx_f - hx_h) - (vx_f - vx_h) * (hz_f - hz_h)) / (span * span)
    st[S_PITCH] = pitch
    tau_pitch = -(prm[P_PITCH_KP] * (pitch + slope) + prm[P_PITCH_KD] * dpitch)
    com_x = hx_h + prm[P_SHARE_FRONT] * (hx_f - hx_h)
    v_mean = 0.5 * (vx_h + vx_f)
    st[S_SPEED_Y] += prm[P_A_SPEED] * (v_mean - st[S_SPEED_Y])
    v_avg = st[S_SPEED_Y]
    if running and prm[P_KI] > 0.0:
        st[S_V_INT] += prm[P_KI] * (v_target - v_avg) * dt
        st[S_V_INT] = max(-prm[P_INT_MAX], min(prm[P_INT_MAX], st[S_V_INT]))
    v_d = v_target + st[S_V_INT]
    lim_tau = prm[P_TAU_LIM]
    nj = int(prm[P_NJ])
    # stance reference constants (BoundController.stance_reference)
    ts = duty * period
    tf = period - ts
    a_ref = math.pi * g * period / (2.0 * ts)
    v0 = -0.5 * g * tf
    k_ref = a_ref * ts / math.pi
    for pair in range(2):
        c, s, hx, hz = kin[pair, 0], kin[pair, 1], kin[pair, 2], kin[pair, 3]
        vx, vz = kin[pair, 4], kin[pair, 5]
        height = hz - hx * tan_s
        m_pair = prm[P_SHARE_HIND + pair] * prm[P_MASS]
        start = 0.0 if pair == 0 else prm[P_PHASE_OFF]
        stance = True
        frac = 0.5
        if running:
            sw0 = (phase - start) % 1.0
            if sw0 < duty:
                frac = sw0 / duty
            else:
                stance = False
        st[S_STANCE_H + pair] = 1.0 if stance else 0.0
        r_x = hx - com_x
        dfz_pitch = -tau_pitch / r_x if abs(r_x) > prm[P_ARM_MIN] else 0.0
        for side_k in range(2):
            leg = 2 * pair + side_k
            o = P_LEGS + LEG_STRIDE * leg
            l1, l2, side = prm[o + L_THIGH], prm[o + L_SHANK], prm[o + L_SIDE]
            i_haa, i_hfe, i_kfe = int(prm[o + L_HAA]), int(prm[o + L_HFE]), int(prm[o + L_KFE])
            haa, h, k = inp[I_JQ + i_haa], inp[I_JQ + i_hfe], inp[I_JQ + i_kfe]
            dhaa, dh, dk = inp[I_JQ + nj + i_haa], inp[I_JQ + nj + i_hfe], inp[I_JQ + nj + i_kfe]
            fx_b, fz_b, fvx_b, fvz_b, j11, j12, j21, j22 = leg_fk(l1, l2, h, k, dh, dk)
            tau_haa = -prm[P_AB_KP] * haa - prm[P_AB_KD] * dhaa
            lo_slot = S_LIFTOFF + 3 * leg
            if stance:
                if running:
                    tau_r = frac * ts
                    sn, cs = math.sin(math.pi * frac), math.cos(math.pi * frac)
                    z_d = (prm[P_HEIGHT] + v0 * tau_r + k_ref * (tau_r - ts / math.pi * sn)
                           - 0.5 * g * tau_r * tau_r)
                    dz_d = v0 + k_ref * (1.0 - cs) - g * tau_r
                    a_d = a_ref * sn - g
                else:
                    z_d, dz_d, a_d = prm[P_HEIGHT], 0.0, 0.0
                fz = m_pair * (g + a_d + prm[P_H_KP] * (z_d - height) + prm[P_H_KD] * (dz_d - vz))
                fz += dfz_pitch
                fz = max(0.0, 0.5 * fz - side * 0.5 * d_roll)
                if running:
                    fx = 0.5 * m_pair * prm[P_SPEED_GAIN] * (v_d - vx)
                else:
                    fx = -0.5 * m_pair * prm[P_STAND_D] * vx
                fx += side * 0.5 * d_yaw * (1.0 if fz > 0.0 else 0.0)
                lim = prm[P_FRIC] * fz
                fx = max(-lim, min(lim, fx))
                ex = -(c * fx - s * fz)
                ez = -(s * fx + c * fz)
                tau_h = j11 * ex + j21 * ez
                tau_k = j12 * ex + j22 * ez
                phi_b, dphi_b = body[pair, 0], body[pair, 1]
                tau_h += 0.5 * (prm[P_BODY_KP] * (phi_b - pitch) + prm[P_BODY_KD] * (dphi_b - dpitch))
                st[lo_slot] = 0.0
            else:
                sw = (phase - start - duty) % 1.0
                sw_frac = min(1.0, sw / (1.0 - duty))
                if st[lo_slot] < 0.5:
                    st[lo_slot] = 1.0
                    st[lo_slot + 1] = c * fx_b + s * fz_b
                    st[lo_slot + 2] = -s * fx_b + c * fz_b
                x_lo, z_lo = st[lo_slot + 1], st[lo_slot + 2]
                x_td = vx * t_stance / 2.0 + prm[P_RAIBERT] * (vx - v_target)
                x_td = max(-prm[P_TD_MAX], min(prm[P_TD_MAX], x_td))
                blend = 0.5 * (1.0 - math.cos(math.pi * sw_frac))
                tx = x_lo + (x_td - x_lo) * blend
                lo_clear = z_lo + height - x_lo * tan_s
                clear = (lo_clear * (1.0 - sw_frac) + prm[P_STEP_H] * math.sin(math.pi * sw_frac)
                         - prm[P_TD_SINK] * sw_frac)
                tz = -height + tx * tan_s + clear
                tbx = c * tx - s * tz
                tbz = s * tx + c * tz
                ex = prm[P_SW_KP] * (tbx - fx_b) - prm[P_SW_KD] * fvx_b
                ez = prm[P_SW_KP] * (tbz - fz_b) - prm[P_SW_KD] * fvz_b
                tau_h = j11 * ex + j21 * ez
                tau_k = j12 * ex + j22 * ez
            out[3 * leg] = max(-lim_tau, min(lim_tau, tau_haa))
            out[3 * leg + 1] = max(-lim_tau, min(lim_tau, tau_h))
            out[3 * leg + 2] = max(-lim_tau, min(lim_tau, tau_k))


def pack(ctrl) -> tuple[np.ndarray, np.ndarray]:
    """(prm, st) for a constructed `BoundController` (its params, world geometry and initial state)."""
    p, w = ctrl.p, ctrl.w
    nj = len(w.movable)
    prm = np.zeros(P_LEGS + LEG_STRIDE * 4)
    vals = {
        P_START: p.start_s, P_SPEED: p.speed_m_s, P_ACCEL: p.accel_m_s2, P_FREQ: p.frequency_hz,
        P_PHASE_OFF: p.phase_offset, P_LAT: p.lateral_gain, P_ROLL_KP: p.roll_kp, P_ROLL_KD: p.roll_kd,
        P_YAW_KP: p.yaw_kp, P_YAW_KD: p.yaw_kd, P_PITCH_KP: p.pitch_kp, P_PITCH_KD: p.pitch_kd,
        P_KI: p.speed_ki, P_INT_MAX: p.speed_int_max, P_HEIGHT: p.height_m, P_H_KP: p.height_kp,
        P_H_KD: p.height_kd, P_SPEED_GAIN: p.speed_gain, P_FRIC: p.friction_use, P_BODY_KP: p.body_kp,
        P_BODY_KD: p.body_kd, P_RAIBERT: p.raibert_gain_s, P_STEP_H: p.step_height_m, P_SW_KP: p.swing_kp,
        P_SW_KD: p.swing_kd, P_AB_KP: p.abduction_kp, P_AB_KD: p.abduction_kd,
        P_DUTY_FIXED: 0.0 if p.duty is None else 1.0, P_DUTY: 0.0 if p.duty is None else p.duty,
        P_DUTY_SLOW: p.duty_slow, P_DUTY_FAST: p.duty_fast, P_DUTY_LO: p.duty_speeds[0],
        P_DUTY_HI: p.duty_speeds[1], P_DT: ctrl.dt, P_SLOPE: ctrl.slope, P_MASS: ctrl.mass,
        P_SHARE_HIND: ctrl.share["hind"], P_SHARE_FRONT: ctrl.share["front"], P_TAU_LIM: ctrl.tau_limit,
        P_LX_HIND: ctrl.lx[ctrl.PAIRS["hind"][0]], P_LX_FRONT: ctrl.lx[ctrl.PAIRS["front"][0]],
        P_G: P.GRAVITY_M_S2, P_A_SPEED: ctrl.speed_f.a, P_A_HIP: ctrl.hip_vel["hind"].a, P_NJ: nj,
        P_YAW_D_MAX: p.yaw_target_max_rad, P_TD_MAX: p.touchdown_max_m, P_ARM_MIN: p.pitch_arm_min_m,
        P_TD_SINK: p.touchdown_sink_m, P_STAND_D: p.stand_damping_1_s,
    }
    links = P.DEFAULT_SPINE.links
    for j in range(3):
        vals[P_LINK0 + j] = links[j].length_m
    for slot, v in vals.items():
        prm[slot] = v
    if ctrl.hip_vz["hind"].a != prm[P_A_HIP] or ctrl.hip_vel["front"].a != prm[P_A_HIP]:
        raise ValueError("the compiled bound assumes one cut-off for the hip velocity filters")
    pim = w.pos_in_movable
    legs = [leg for pair in ("hind", "front") for leg in ctrl.PAIRS[pair]]
    if tuple(legs) != LEGS:
        raise ValueError(f"the compiled bound expects the legs {LEGS}, got {legs}")
    for n, leg in enumerate(LEGS):
        meta = ctrl.legs[leg]
        o = P_LEGS + LEG_STRIDE * n
        prm[o + L_THIGH], prm[o + L_SHANK] = meta["thigh_m"], meta["shank_m"]
        prm[o + L_SIDE] = 1.0 if leg[1] == "L" else -1.0
        prm[o + L_HAA], prm[o + L_HFE], prm[o + L_KFE] = (pim[j] for j in w.leg_idx[leg])
    st = np.zeros(STATE_SIZE)
    st[S_V_TARGET], st[S_V_INT], st[S_PHASE], st[S_DUTY] = ctrl.v_target, ctrl.v_int, ctrl.phase, ctrl.duty
    st[S_STANCE_H] = st[S_STANCE_F] = 1.0
    return prm, st
