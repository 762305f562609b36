"""One whole control step (kinematics, eq. 3 with one RNEA pass, eq. 4, eq. 5, clamp) as a single function
over flat float arrays, so that numba can compile it (`spine_module.control.compiled`).

Why: the step's maths is ~1 us; the numpy/pinocchio path spends ~40x that on Python overhead for
3-vectors. Nothing here is a copied constant: `pack_model` reads joint placements, axes, inertias,
armature, gravity and the end-effector frame from the `pin.Model`s of a `SpineModel`, and the pinocchio
path in `ImpedanceController`/`TaskPDController` stays the reference (checked to 1e-9 in the tests).

This module imports neither numba nor pinocchio at import time, and all the layout constants live here,
next to the kernel, so numba's on-disk cache (keyed on this file) can never pair a kernel with a stale
layout. Plain Python can run `spine_step` too (slowly): it is the same code the compiler sees.

Layout of the packed array `prm` (float64):
  header (HEADER): n (dynamics joints), nk (kinematic joints), offsets of gravity, dynamics joints,
  kinematic joints, end-effector frame and the controller section.
  dynamics joint record (DYN_STRIDE): placement R (9, row-major), p (3, m), axis (3), mass (kg), com (3, m),
  rotational inertia about the com (9, kg*m^2), armature (kg*m^2).
  kinematic joint record (KIN_STRIDE): placement R (9), p (3, m), axis (3).
  end-effector frame: R (9), p (3, m) in its parent joint's frame (the last kinematic joint).
  controller section: see the C_* offsets below; friction rows (FRIC_STRIDE per actuated joint).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

# header slots
H_N, H_NK, H_GRAV, H_DYN, H_KIN, H_EE, H_CTRL = 0, 1, 2, 3, 4, 5, 6
HEADER = 8
DYN_STRIDE = 29
KIN_STRIDE = 15
EE_SIZE = 12
# controller section, relative to prm[H_CTRL]
C_MODE, C_FRICTION_ON, C_LAMBDA2 = 0, 1, 2
C_X_D, C_DX_D, C_DDX_D, C_K, C_D = 3, 6, 9, 12, 15
C_TAU_MAX = 18  # nk values, N*m
C_FRICTION = 18  # + nk: rows (tau_c, tau_s - tau_c, 1/dq_s, alpha, beta, b) per actuated joint
FRIC_STRIDE = 6
MODE_PD, MODE_IMPEDANCE = 0.0, 1.0
# result array: tau (nk), tau_raw (nk), x (3), dx (3), then scratch
R_TAU, R_TAU_RAW = 0, 1  # in units of nk
SCRATCH_PER_JOINT = 40

OK, NOT_FINITE, BAD_SHAPE = 1, 0, -1



def inertia_apply(prm: np.ndarray, o: int, mx: float, my: float, mz: float, wx: float, wy: float,
                  wz: float) -> tuple[float, float, float, float, float, float]:
    """A body's spatial inertia (prm[o]: mass, then the COM c (3), then the rotational inertia about the
    COM, row-major (9)) times the motion (m_lin, m_ang): lin = mass (m_lin - c x m_ang), ang = Ic m_ang +
    c x lin. `control.compiled` makes it callable from the compiled step."""
    mass = prm[o]
    kx, ky, kz = prm[o + 1], prm[o + 2], prm[o + 3]
    la = mass * (mx - (ky * wz - kz * wy))
    lb = mass * (my - (kz * wx - kx * wz))
    lc = mass * (mz - (kx * wy - ky * wx))
    na = prm[o + 4] * wx + prm[o + 5] * wy + prm[o + 6] * wz + ky * lc - kz * lb
    nb = prm[o + 7] * wx + prm[o + 8] * wy + prm[o + 9] * wz + kz * la - kx * lc
    nc = prm[o + 10] * wx + prm[o + 11] * wy + prm[o + 12] * wz + kx * lb - ky * la
    return la, lb, lc, na, nb, nc


def _axis(joint: Any) -> tuple[float, float, float]:
    """Rotation axis of a revolute joint model; anything else is not supported by the kernel."""
    name = joint.shortname()
    unit = {"JointModelRX": (1.0, 0.0, 0.0), "JointModelRY": (0.0, 1.0, 0.0), "JointModelRZ": (0.0, 0.0, 1.0)}
    if name in unit:
        return unit[name]
    if name == "JointModelRevoluteUnaligned":
        a = np.asarray(joint.extract().axis, dtype=float)
        return tuple(float(v) for v in a / np.linalg.norm(a))
    raise NotImplementedError(f"compiled control step supports revolute joints only, got {name}")


def _serial(model: Any) -> None:
    parents = list(model.parents)
    if parents[1:] != list(range(model.njoints - 1)) or model.nq != model.nv:
        raise NotImplementedError("compiled control step needs a serial chain of 1-DoF joints")


def result_size(nk: int) -> int:
    return 2 * nk + 6 + SCRATCH_PER_JOINT * (nk + 2)


def pack_model(spine_model: Any, n_task: int = 3) -> np.ndarray:
    """Flat array of everything the kernel needs from `spine_model.model` (dynamics, true q1) and
    `spine_model.kin_model` (relative kinematics, q1 locked), plus a zeroed controller section."""
    model, kin = spine_model.model, spine_model.kin_model
    _serial(model)
    _serial(kin)
    n, nk = model.nv, kin.nv
    if n - nk != 1 or n_task != 3:
        raise NotImplementedError("compiled control step expects one passive base joint and a 3-D task")
    frame = kin.frames[spine_model.ee_frame]
    if frame.parentJoint != kin.njoints - 1:
        raise NotImplementedError("end-effector frame must hang on the last joint")
    off_grav = HEADER
    off_dyn = off_grav + 3
    off_kin = off_dyn + n * DYN_STRIDE
    off_ee = off_kin + nk * KIN_STRIDE
    off_ctrl = off_ee + EE_SIZE
    prm = np.zeros(off_ctrl + C_FRICTION + nk + FRIC_STRIDE * nk)
    prm[H_N], prm[H_NK] = n, nk
    prm[H_GRAV], prm[H_DYN], prm[H_KIN], prm[H_EE], prm[H_CTRL] = off_grav, off_dyn, off_kin, off_ee, off_ctrl
    prm[off_grav:off_grav + 3] = model.gravity.linear
    for i in range(n):
        j = i + 1
        o = off_dyn + i * DYN_STRIDE
        M = model.jointPlacements[j]
        inertia = model.inertias[j]
        prm[o:o + 9] = M.rotation.reshape(-1)
        prm[o + 9:o + 12] = M.translation
        prm[o + 12:o + 15] = _axis(model.joints[j])
        prm[o + 15] = inertia.mass
        prm[o + 16:o + 19] = inertia.lever
        prm[o + 19:o + 28] = inertia.inertia.reshape(-1)
        prm[o + 28] = model.armature[i]
    for i in range(nk):
        j = i + 1
        o = off_kin + i * KIN_STRIDE
        M = kin.jointPlacements[j]
        prm[o:o + 9] = M.rotation.reshape(-1)
        prm[o + 9:o + 12] = M.translation
        prm[o + 12:o + 15] = _axis(kin.joints[j])
    prm[off_ee:off_ee + 9] = frame.placement.rotation.reshape(-1)
    prm[off_ee + 9:off_ee + 12] = frame.placement.translation
    return prm


def spine_step(prm: np.ndarray, q: np.ndarray, dq: np.ndarray, ddq1: float, acc: np.ndarray, res: np.ndarray,
               sat: np.ndarray) -> int:
    """One control step. q, dq: [q1..qn] (rad, rad/s); ddq1: torso acceleration (rad/s^2); acc (3): linear
    acceleration of the base joint's origin in the base body's frame (the hind body), m/s^2, gravity not
    included (zeros: the fixed-origin law). It enters as the base body's linear acceleration, which is
    RNEA with gravity g - a (world frame) at the first body: the same as a prismatic base accelerating at a.

    Writes tau, tau_raw (N*m), x (m, m, rad), dx into `res` and the clamp flags into `sat`. Returns OK,
    NOT_FINITE (nothing written but scratch) or BAD_SHAPE.
    """
    n = int(prm[H_N])
    nk = int(prm[H_NK])
    if (q.shape[0] != n or dq.shape[0] != n or sat.shape[0] != nk or acc.shape[0] != 3
            or res.shape[0] < 2 * nk + 6 + 40 * (nk + 2)):
        return BAD_SHAPE
    og, od, ok_, oe, oc = int(prm[H_GRAV]), int(prm[H_DYN]), int(prm[H_KIN]), int(prm[H_EE]), int(prm[H_CTRL])
    base = n - nk
    s = 2 * nk + 6  # scratch start
    # scratch: per kinematic joint z (3) and origin p (3); J (3 x nk); then dynamics per joint
    sz = s
    sp = sz + 3 * nk
    sJ = sp + 3 * nk
    sddq = sJ + 3 * nk
    sdyn = sddq + n  # per dynamics joint: R (9), v (6), a (6), f (6) = 27
    # ---- relative kinematics on the chain q[base:], world = hind-body frame -------------------------
    R00, R01, R02, R10, R11, R12, R20, R21, R22 = 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0
    px = py = pz = 0.0  # current joint origin
    wx = wy = wz = 0.0  # angular velocity of the current body
    vx = vy = vz = 0.0  # linear velocity of the current joint origin
    alx = aly = alz = 0.0  # angular acceleration (ddq = 0)
    ax = ay = az = 0.0  # linear acceleration of the current origin (ddq = 0)
    for i in range(nk):
        o = ok_ + i * KIN_STRIDE
        # origin of joint i in world: p + R t
        tx, ty, tz = prm[o + 9], prm[o + 10], prm[o + 11]
        rx = R00 * tx + R01 * ty + R02 * tz
        ry = R10 * tx + R11 * ty + R12 * tz
        rz = R20 * tx + R21 * ty + R22 * tz
        # velocity and acceleration of the new origin from the parent body's motion
        vx, vy, vz = vx + wy * rz - wz * ry, vy + wz * rx - wx * rz, vz + wx * ry - wy * rx
        cx, cy, cz = wy * rz - wz * ry, wz * rx - wx * rz, wx * ry - wy * rx  # w x r
        ax += aly * rz - alz * ry + wy * cz - wz * cy
        ay += alz * rx - alx * rz + wz * cx - wx * cz
        az += alx * ry - aly * rx + wx * cy - wy * cx
        px += rx
        py += ry
        pz += rz
        # R <- R * placement.R
        n00 = R00 * prm[o] + R01 * prm[o + 3] + R02 * prm[o + 6]
        n01 = R00 * prm[o + 1] + R01 * prm[o + 4] + R02 * prm[o + 7]
        n02 = R00 * prm[o + 2] + R01 * prm[o + 5] + R02 * prm[o + 8]
        n10 = R10 * prm[o] + R11 * prm[o + 3] + R12 * prm[o + 6]
        n11 = R10 * prm[o + 1] + R11 * prm[o + 4] + R12 * prm[o + 7]
        n12 = R10 * prm[o + 2] + R11 * prm[o + 5] + R12 * prm[o + 8]
        n20 = R20 * prm[o] + R21 * prm[o + 3] + R22 * prm[o + 6]
        n21 = R20 * prm[o + 1] + R21 * prm[o + 4] + R22 * prm[o + 7]
        n22 = R20 * prm[o + 2] + R21 * prm[o + 5] + R22 * prm[o + 8]
        ux, uy, uz = prm[o + 12], prm[o + 13], prm[o + 14]
        # joint axis in world (fixed in both the parent and the child body)
        zx = n00 * ux + n01 * uy + n02 * uz
        zy = n10 * ux + n11 * uy + n12 * uz
        zw = n20 * ux + n21 * uy + n22 * uz
        res[sz + 3 * i], res[sz + 3 * i + 1], res[sz + 3 * i + 2] = zx, zy, zw
        res[sp + 3 * i], res[sp + 3 * i + 1], res[sp + 3 * i + 2] = px, py, pz
        qi, dqi = q[base + i], dq[base + i]
        alx += (wy * zw - wz * zy) * dqi
        aly += (wz * zx - wx * zw) * dqi
        alz += (wx * zy - wy * zx) * dqi
        wx += zx * dqi
        wy += zy * dqi
        wz += zw * dqi
        # R <- R * Rot(u, q) (Rodrigues)
        c, sn = math.cos(qi), math.sin(qi)
        t = 1.0 - c
        e00, e01, e02 = c + t * ux * ux, t * ux * uy - sn * uz, t * ux * uz + sn * uy
        e10, e11, e12 = t * ux * uy + sn * uz, c + t * uy * uy, t * uy * uz - sn * ux
        e20, e21, e22 = t * ux * uz - sn * uy, t * uy * uz + sn * ux, c + t * uz * uz
        R00, R01, R02 = n00 * e00 + n01 * e10 + n02 * e20, n00 * e01 + n01 * e11 + n02 * e21, \
            n00 * e02 + n01 * e12 + n02 * e22
        R10, R11, R12 = n10 * e00 + n11 * e10 + n12 * e20, n10 * e01 + n11 * e11 + n12 * e21, \
            n10 * e02 + n11 * e12 + n12 * e22
        R20, R21, R22 = n20 * e00 + n21 * e10 + n22 * e20, n20 * e01 + n21 * e11 + n22 * e21, \
            n20 * e02 + n21 * e12 + n22 * e22
    # end-effector frame
    tx, ty, tz = prm[oe + 9], prm[oe + 10], prm[oe + 11]
    rx = R00 * tx + R01 * ty + R02 * tz
    ry = R10 * tx + R11 * ty + R12 * tz
    rz = R20 * tx + R21 * ty + R22 * tz
    cx, cy, cz = wy * rz - wz * ry, wz * rx - wx * rz, wx * ry - wy * rx
    ax += aly * rz - alz * ry + wy * cz - wz * cy
    ay += alz * rx - alx * rz + wz * cx - wx * cz
    az += alx * ry - aly * rx + wx * cy - wy * cx
    ex, ey, ez = px + rx, py + ry, pz + rz
    f00 = R00 * prm[oe] + R01 * prm[oe + 3] + R02 * prm[oe + 6]
    f02 = R00 * prm[oe + 2] + R01 * prm[oe + 5] + R02 * prm[oe + 8]
    # task Jacobian rows (x, z, pitch) = linear x, linear z, angular y of the LOCAL_WORLD_ALIGNED Jacobian
    x0, x1, x2 = ex, ez, math.atan2(f02, f00)
    dx0 = dx1 = dx2 = 0.0
    for i in range(nk):
        zx, zy, zw = res[sz + 3 * i], res[sz + 3 * i + 1], res[sz + 3 * i + 2]
        lx, ly, lz = ex - res[sp + 3 * i], ey - res[sp + 3 * i + 1], ez - res[sp + 3 * i + 2]
        j0 = zy * lz - zw * ly
        j1 = zx * ly - zy * lx
        j2 = zy
        res[sJ + i], res[sJ + nk + i], res[sJ + 2 * nk + i] = j0, j1, j2
        dqi = dq[base + i]
        dx0 += j0 * dqi
        dx1 += j1 * dqi
        dx2 += j2 * dqi
    jd0, jd1, jd2 = ax, az, aly  # J̇q̇: classical acceleration of the frame at ddq = 0
    # ---- spring-damper F = K (x_d - x) + D (dx_d - dx), theta error wrapped to (-pi, pi] --------------
    e0 = prm[oc + C_X_D] - x0
    e1 = prm[oc + C_X_D + 1] - x1
    e2 = (prm[oc + C_X_D + 2] - x2 + math.pi) % (2 * math.pi) - math.pi
    F0 = prm[oc + C_K] * e0 + prm[oc + C_D] * (prm[oc + C_DX_D] - dx0)
    F1 = prm[oc + C_K + 1] * e1 + prm[oc + C_D + 1] * (prm[oc + C_DX_D + 1] - dx1)
    F2 = prm[oc + C_K + 2] * e2 + prm[oc + C_D + 2] * (prm[oc + C_DX_D + 2] - dx2)
    traw = nk * R_TAU_RAW
    if prm[oc + C_MODE] == MODE_PD:
        for i in range(nk):
            res[traw + i] = res[sJ + i] * F0 + res[sJ + nk + i] * F1 + res[sJ + 2 * nk + i] * F2
    else:
        # ---- eq. 3: ddq* = [ddq1, J†(ddx_d - J̇q̇)], J† = Jᵀ(JJᵀ + λ²I)⁻¹ --------------------------
        b0 = prm[oc + C_DDX_D] - jd0
        b1 = prm[oc + C_DDX_D + 1] - jd1
        b2 = prm[oc + C_DDX_D + 2] - jd2
        lam2 = prm[oc + C_LAMBDA2]
        a00 = a01 = a02 = a11 = a12 = a22 = 0.0
        for i in range(nk):
            g0, g1, g2 = res[sJ + i], res[sJ + nk + i], res[sJ + 2 * nk + i]
            a00 += g0 * g0
            a01 += g0 * g1
            a02 += g0 * g2
            a11 += g1 * g1
            a12 += g1 * g2
            a22 += g2 * g2
        a00 += lam2
        a11 += lam2
        a22 += lam2
        # symmetric 3x3 solve by the adjugate (JJᵀ + λ²I is positive definite)
        c00 = a11 * a22 - a12 * a12
        c01 = a02 * a12 - a01 * a22
        c02 = a01 * a12 - a02 * a11
        c11 = a00 * a22 - a02 * a02
        c12 = a01 * a02 - a00 * a12
        c22 = a00 * a11 - a01 * a01
        det = a00 * c00 + a01 * c01 + a02 * c02
        y0 = (c00 * b0 + c01 * b1 + c02 * b2) / det
        y1 = (c01 * b0 + c11 * b1 + c12 * b2) / det
        y2 = (c02 * b0 + c12 * b1 + c22 * b2) / det
        for i in range(base):
            res[sddq + i] = ddq1
        for i in range(nk):
            res[sddq + base + i] = res[sJ + i] * y0 + res[sJ + nk + i] * y1 + res[sJ + 2 * nk + i] * y2
        # ---- one RNEA pass (pinocchio's local-frame recursion) at (q, dq, ddq*) -----------------------
        # forward: v, a of each body in its own frame; a_0 = -gravity
        pvx, pvy, pvz, pwx, pwy, pwz = 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
        pax, pay, paz = -prm[og], -prm[og + 1], -prm[og + 2]
        pbx = pby = pbz = 0.0
        for i in range(n):
            o = od + i * DYN_STRIDE
            d = sdyn + i * 27
            ux, uy, uz = prm[o + 12], prm[o + 13], prm[o + 14]
            qi, dqi, ddqi = q[i], dq[i], res[sddq + i]
            c, sn = math.cos(qi), math.sin(qi)
            t = 1.0 - c
            e00, e01, e02 = c + t * ux * ux, t * ux * uy - sn * uz, t * ux * uz + sn * uy
            e10, e11, e12 = t * ux * uy + sn * uz, c + t * uy * uy, t * uy * uz - sn * ux
            e20, e21, e22 = t * ux * uz - sn * uy, t * uy * uz + sn * ux, c + t * uz * uz
            # liMi rotation = placement.R * Rot(u, q); translation = placement.p
            r00 = prm[o] * e00 + prm[o + 1] * e10 + prm[o + 2] * e20
            r01 = prm[o] * e01 + prm[o + 1] * e11 + prm[o + 2] * e21
            r02 = prm[o] * e02 + prm[o + 1] * e12 + prm[o + 2] * e22
            r10 = prm[o + 3] * e00 + prm[o + 4] * e10 + prm[o + 5] * e20
            r11 = prm[o + 3] * e01 + prm[o + 4] * e11 + prm[o + 5] * e21
            r12 = prm[o + 3] * e02 + prm[o + 4] * e12 + prm[o + 5] * e22
            r20 = prm[o + 6] * e00 + prm[o + 7] * e10 + prm[o + 8] * e20
            r21 = prm[o + 6] * e01 + prm[o + 7] * e11 + prm[o + 8] * e21
            r22 = prm[o + 6] * e02 + prm[o + 7] * e12 + prm[o + 8] * e22
            res[d], res[d + 1], res[d + 2] = r00, r01, r02
            res[d + 3], res[d + 4], res[d + 5] = r10, r11, r12
            res[d + 6], res[d + 7], res[d + 8] = r20, r21, r22
            tx, ty, tz = prm[o + 9], prm[o + 10], prm[o + 11]
            # actInv: v_c = Rᵀ(v + w x p), w_c = Rᵀ w (velocity)
            hx = pvx + pwy * tz - pwz * ty
            hy = pvy + pwz * tx - pwx * tz
            hz = pvz + pwx * ty - pwy * tx
            vx = r00 * hx + r10 * hy + r20 * hz
            vy = r01 * hx + r11 * hy + r21 * hz
            vz = r02 * hx + r12 * hy + r22 * hz
            wx = r00 * pwx + r10 * pwy + r20 * pwz + ux * dqi
            wy = r01 * pwx + r11 * pwy + r21 * pwz + uy * dqi
            wz = r02 * pwx + r12 * pwy + r22 * pwz + uz * dqi
            # acceleration: actInv of parent's + S ddq + v x (S dq)
            hx = pax + pby * tz - pbz * ty
            hy = pay + pbz * tx - pbx * tz
            hz = paz + pbx * ty - pby * tx
            sx, sy, sw = ux * dqi, uy * dqi, uz * dqi
            aax = r00 * hx + r10 * hy + r20 * hz + vy * sw - vz * sy
            aay = r01 * hx + r11 * hy + r21 * hz + vz * sx - vx * sw
            aaz = r02 * hx + r12 * hy + r22 * hz + vx * sy - vy * sx
            bbx = r00 * pbx + r10 * pby + r20 * pbz + ux * ddqi + wy * sw - wz * sy
            bby = r01 * pbx + r11 * pby + r21 * pbz + uy * ddqi + wz * sx - wx * sw
            bbz = r02 * pbx + r12 * pby + r22 * pbz + uz * ddqi + wx * sy - wy * sx
            if i == 0:  # the base body: its origin's linear acceleration (its own frame) joins -gravity
                aax += acc[0]
                aay += acc[1]
                aaz += acc[2]
            # f = I a + v x* (I v)
            la, lb, lc, na, nb, nc = inertia_apply(prm, o + 15, aax, aay, aaz, bbx, bby, bbz)
            hl0, hl1, hl2, ha0, ha1, ha2 = inertia_apply(prm, o + 15, vx, vy, vz, wx, wy, wz)
            # v x* h = (w x h_lin, w x h_ang + v x h_lin)
            res[d + 9] = la + wy * hl2 - wz * hl1
            res[d + 10] = lb + wz * hl0 - wx * hl2
            res[d + 11] = lc + wx * hl1 - wy * hl0
            res[d + 12] = na + wy * ha2 - wz * ha1 + vy * hl2 - vz * hl1
            res[d + 13] = nb + wz * ha0 - wx * ha2 + vz * hl0 - vx * hl2
            res[d + 14] = nc + wx * ha1 - wy * ha0 + vx * hl1 - vy * hl0
            pvx, pvy, pvz, pwx, pwy, pwz = vx, vy, vz, wx, wy, wz
            pax, pay, paz, pbx, pby, pbz = aax, aay, aaz, bbx, bby, bbz
        # backward: tau_i = Sᵀ f_i + armature ddq_i; f_parent += liMi f_i
        for i in range(n - 1, -1, -1):
            o = od + i * DYN_STRIDE
            d = sdyn + i * 27
            fl0, fl1, fl2 = res[d + 9], res[d + 10], res[d + 11]
            fa0, fa1, fa2 = res[d + 12], res[d + 13], res[d + 14]
            tau = prm[o + 12] * fa0 + prm[o + 13] * fa1 + prm[o + 14] * fa2 + prm[o + 28] * res[sddq + i]
            if i >= base:
                # tau_raw = RNEA + Jᵀ F (eq. 3)
                k = i - base
                res[traw + k] = tau + res[sJ + k] * F0 + res[sJ + nk + k] * F1 + res[sJ + 2 * nk + k] * F2
            if i > 0:
                tx, ty, tz = prm[o + 9], prm[o + 10], prm[o + 11]
                g0 = res[d] * fl0 + res[d + 1] * fl1 + res[d + 2] * fl2
                g1 = res[d + 3] * fl0 + res[d + 4] * fl1 + res[d + 5] * fl2
                g2 = res[d + 6] * fl0 + res[d + 7] * fl1 + res[d + 8] * fl2
                h0 = res[d] * fa0 + res[d + 1] * fa1 + res[d + 2] * fa2 + ty * g2 - tz * g1
                h1 = res[d + 3] * fa0 + res[d + 4] * fa1 + res[d + 5] * fa2 + tz * g0 - tx * g2
                h2 = res[d + 6] * fa0 + res[d + 7] * fa1 + res[d + 8] * fa2 + tx * g1 - ty * g0
                pd = sdyn + (i - 1) * 27
                res[pd + 9] += g0
                res[pd + 10] += g1
                res[pd + 11] += g2
                res[pd + 12] += h0
                res[pd + 13] += h1
                res[pd + 14] += h2
        # ---- eq. 4: Stribeck friction compensation ---------------------------------------------------
        if prm[oc + C_FRICTION_ON] != 0.0:
            of = oc + C_FRICTION + nk
            for k in range(nk):
                r = of + k * FRIC_STRIDE
                v = dq[base + k]
                res[traw + k] += ((prm[r] + prm[r + 1] * math.exp(-((abs(v) * prm[r + 2]) ** prm[r + 3])))
                                  * math.tanh(prm[r + 4] * v) + prm[r + 5] * v)
    # ---- NaN/inf anywhere shows in the torque or the pose: check once, then clamp --------------------
    total = x0 + x1 + x2
    for k in range(nk):
        total += res[traw + k]
    if not math.isfinite(total):
        return NOT_FINITE
    for k in range(nk):
        raw = res[traw + k]
        hi = prm[oc + C_TAU_MAX + k]
        tau = min(max(raw, -hi), hi)
        res[k] = tau
        sat[k] = tau != raw
    ox = 2 * nk
    res[ox], res[ox + 1], res[ox + 2] = x0, x1, x2
    res[ox + 3], res[ox + 4], res[ox + 5] = dx0, dx1, dx2
    return OK
