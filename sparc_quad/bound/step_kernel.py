"""The control half of one bound step, whole, as one function over flat arrays that numba compiles
(`sim.step_compiled`; `bound.compiled_loop` drives it): the torso estimate, the spine law and the node's
output stage, the bound controller, the torques in the engine's joint order, the log row and the fall check.

Why: with both controllers compiled, the Python around them (estimator, wrappers, torque ordering, the
log row, the fall check) still cost ~40 us per 1 kHz step inside the loop, where pybullet's step takes
~60 us (notebook/2026-12-03-amd-host.md). Here that glue is one call.

What it runs is the reference loop's arithmetic, operation for operation, on the same doubles:
`Estimator.update` (base motion "fixed"), `DirectSpine.begin` on the compiled impedance law
(`spine_module.control.kernel.spine_step`, the same kernel) with `spine_module.safety.limit_torque`,
`CompiledBoundController.step` (the same `gaits.bound_kernel.bound_step`), `QuadWorld.set_torques`'s order,
`run_bound`'s log row and `fall_code`. tests/sparc_quad/sim/test_compiled_loop.py compares whole bounds
with the reference loop bit for bit. This module imports neither numba nor pybullet.

Arrays (float64 unless said): `ws` is one workspace, its first W_SIZE slots the offsets of its parts (see
`W_*`); `cols` (int64) the log column of each KERNEL_ROW value; `noise` the estimator's current block of
standard normals (rows of 3), `k` the row this step uses.
"""

from __future__ import annotations

import numpy as np

from sparc_quad.gaits.bound_kernel import (
    I_DQ1,
    I_DQS0,
    I_JQ,
    I_Q1,
    I_QS0,
    I_ROLL,
    I_T,
    I_X,
    I_Y,
    I_YAW,
    I_Z,
    P_FREQ,
    P_NJ,
    S_PHASE,
    S_STANCE_F,
    S_STANCE_H,
    bound_step,
)
from sparc_quad.sim.fall import fall_code
from spine_module.control.kernel import OK, spine_step

# workspace header: the offset of each part in `ws`
(W_INP, W_QDQ, W_ZACC, W_GOUT, W_EPRM, W_EST, W_LIM, W_ORDER, W_LEGDQ, W_TAU, W_NTAU) = range(11)
W_SIZE = 11
# after the bound controller's inputs (gaits.bound_kernel I_*, then jq and jdq), the loop's own inputs
X_CONTACT = 0  # normal force on each foot, HL, HR, FL, FR, N
X_BODY = 4  # 1.0: a body link touches the ground
X_SIZE = 5
# estimator parameters (eprm) and state (est)
(E_Q1_BIAS, E_Q1_NOISE, E_DQ1_BIAS, E_DQ1_NOISE, E_DDQ1_NOISE, E_DT, E_ALPHA, E_LEN, E_TORSO_ACCEL,
 E_SLOPE) = range(10)
E_PRM_SIZE = 10
(ES_HAS_PREV, ES_PREV_DQ1, ES_ACC, ES_START, ES_COUNT) = range(5)
ES_RING = 5  # then E_LEN entries of (q1, dq1, ddq1), oldest at ES_START
# output stage (safety.TorqueLimits): lower (3), upper (3), margin, damping, torque, clear (6)
(L_LO, L_HI, L_MARGIN, L_DAMPING, L_TORQUE, L_CLEAR) = (0, 3, 6, 7, 8, 9)
L_SIZE = 15
# the values of a log row the kernel writes, in this order (`cols` maps each to its column)
KERNEL_ROW = ("t", "x", "y", "z", "q1_true", "dq1_true", "q1_est", "dq1_est", "ddq1_est", "pitch_front",
              "roll", "yaw", "q2", "q3", "q4", "dq2", "dq3", "dq4", "tau2", "tau3", "tau4", "spine_x",
              "spine_z", "spine_theta", "contact_HL", "contact_HR", "contact_FL", "contact_FR", "stance_hind",
              "stance_front", "gait_phase", "gait_frequency_hz", "spine_spring_energy_j")
K_LEG_TAU = len(KERNEL_ROW)  # then the 12 leg torques (HL, HR, FL, FR x HAA, HFE, KFE), then their 12 rates
K_SIZE = K_LEG_TAU + 24

def limit_torque3(a: float, b: float, c: float, qa: float, qb: float, qc: float, dqa: float, dqb: float,
                  dqc: float, lim: np.ndarray) -> tuple[float, float, float]:
    """`spine_module.safety.limit_torque` on scalars: the joint-limit damping inside the margin (margin > 0),
    then the clamp; a non-finite torque becomes 0 (Python's min/max semantics, written out)."""
    if not (lim[L_CLEAR] <= qa <= lim[L_CLEAR + 1] and lim[L_CLEAR + 2] <= qb <= lim[L_CLEAR + 3]
            and lim[L_CLEAR + 4] <= qc <= lim[L_CLEAR + 5]):
        margin, damp = lim[L_MARGIN], lim[L_DAMPING]
        e0, n0 = _limit_damping(qa, dqa, lim[L_LO], lim[L_HI], margin, damp)
        e1, n1 = _limit_damping(qb, dqb, lim[L_LO + 1], lim[L_HI + 1], margin, damp)
        e2, n2 = _limit_damping(qc, dqc, lim[L_LO + 2], lim[L_HI + 2], margin, damp)
        if n0 or n1 or n2:
            a, b, c = a + e0, b + e1, c + e2
    t = lim[L_TORQUE]
    if -t <= a <= t and -t <= b <= t and -t <= c <= t:
        return a, b, c
    return _clamp(a, t), _clamp(b, t), _clamp(c, t)


def _limit_damping(q: float, dq: float, lo: float, hi: float, margin: float,
                   damp: float) -> tuple[float, bool]:
    """One joint of `safety.joint_limit_damping_list`'s loop."""
    d = (q - (hi - margin)) / margin
    d = d if d > 0.0 else 0.0  # max(0.0, d)
    depth_hi = d if d < 1.0 else 1.0  # min(1.0, d)
    d = ((lo + margin) - q) / margin
    d = d if d > 0.0 else 0.0
    depth_lo = d if d < 1.0 else 1.0
    towards = depth_hi if dq > 0 else depth_lo
    return -damp * towards * dq, depth_hi > 0 or depth_lo > 0


def _clamp(v: float, limit: float) -> float:
    """One value of `safety.clamp_torque_list`'s loop."""
    if not np.isfinite(v):
        return 0.0
    return limit if v > limit else -limit if v < -limit else v


def estimate(eprm: np.ndarray, est: np.ndarray, n0: float, n1: float, n2: float, q1: float,
             dq1: float) -> tuple[float, float, float]:
    """`Estimator.update` ("fixed" base motion) with this step's normals: (q1, dq1, ddq1) the torso
    estimate gives now, the oldest of the delay line."""
    mq = q1 + eprm[E_Q1_BIAS] + eprm[E_Q1_NOISE] * n0
    mdq = dq1 + eprm[E_DQ1_BIAS] + eprm[E_DQ1_NOISE] * n1
    raw = 0.0 if est[ES_HAS_PREV] == 0.0 else (dq1 - est[ES_PREV_DQ1]) / eprm[E_DT]
    est[ES_HAS_PREV] = 1.0
    est[ES_PREV_DQ1] = dq1
    est[ES_ACC] += eprm[E_ALPHA] * (raw - est[ES_ACC])
    length = int(eprm[E_LEN])
    start, count = int(est[ES_START]), int(est[ES_COUNT])
    if count < length:
        slot = (start + count) % length
        est[ES_COUNT] = count + 1
    else:  # full: the newest replaces the oldest
        slot = start
        start = (start + 1) % length
        est[ES_START] = start
    o = ES_RING + 3 * slot
    est[o], est[o + 1], est[o + 2] = mq, mdq, est[ES_ACC] + eprm[E_DDQ1_NOISE] * n2
    o = ES_RING + 3 * start
    return est[o], est[o + 1], est[o + 2]


def control_step(sprm: np.ndarray, res: np.ndarray, sat: np.ndarray, gprm: np.ndarray, gst: np.ndarray,
                 ws: np.ndarray, cols: np.ndarray, noise: np.ndarray, k: int, log: np.ndarray,
                 i: int) -> int:
    """Row `i` of the bound from the state packed in ws's input part: the torques into ws's torque part
    (the engine's joint order) and the log row into `log[i]`. Returns `fall_code` of that state."""
    inp = ws[int(ws[W_INP]):]
    nj = int(gprm[P_NJ])
    x = I_JQ + 2 * nj  # the loop's own inputs
    eprm = ws[int(ws[W_EPRM]):]
    slope = eprm[E_SLOPE]
    q1, dq1 = inp[I_Q1], inp[I_DQ1]
    qa, qb, qc = inp[I_QS0], inp[I_QS0 + 1], inp[I_QS0 + 2]
    dqa, dqb, dqc = inp[I_DQS0], inp[I_DQS0 + 1], inp[I_DQS0 + 2]
    pitch_front = q1 + (((0.0 + qa) + qb) + qc)  # q1 + sum(q_spine), as Python sums
    roll = inp[I_ROLL]
    code = fall_code(inp[x + X_BODY] > 0.5, q1, pitch_front, roll, slope)
    # the torso estimate
    eq1, edq1, eddq1 = estimate(eprm, ws[int(ws[W_EST]):], noise[k, 0], noise[k, 1], noise[k, 2], q1, dq1)
    # the spine: the impedance law, then the node's output stage
    qdq = ws[int(ws[W_QDQ]):int(ws[W_QDQ]) + 8]
    qdq[0], qdq[1], qdq[2], qdq[3] = eq1, qa, qb, qc
    qdq[4], qdq[5], qdq[6], qdq[7] = edq1, dqa, dqb, dqc
    ddq1 = eddq1 if eprm[E_TORSO_ACCEL] != 0.0 else 0.0
    oz = int(ws[W_ZACC])
    if spine_step(sprm, qdq[0:4], qdq[4:8], ddq1, ws[oz:oz + 3], res, sat) != OK:
        res[0:6] = 0.0  # as TaskController._fail: no torque
        sat[:] = False
    lim = ws[int(ws[W_LIM]):]
    ta, tb, tc = limit_torque3(res[0], res[1], res[2], qa, qb, qc, dqa, dqb, dqc, lim)
    # the legs
    og = int(ws[W_GOUT])
    gout = ws[og:og + 12]
    bound_step(gprm, gst, inp, gout)
    # every joint's torque in the engine's order (QuadWorld.set_torques: spine, legs, then 0 for the rest)
    ot, oo, ntau = int(ws[W_TAU]), int(ws[W_ORDER]), int(ws[W_NTAU])
    for p in range(ntau):
        j = int(ws[oo + p])
        ws[ot + p] = ta if j == 0 else tb if j == 1 else tc if j == 2 else gout[j - 3] if j < 15 else 0.0
    # the log row: the state the torques were computed from
    row = log[i]
    vals = (inp[I_T], inp[I_X], inp[I_Y], inp[I_Z], q1, dq1, eq1, edq1, eddq1, pitch_front, roll,
            inp[I_YAW], qa, qb, qc, dqa, dqb, dqc, ta, tb, tc, res[6], res[7], res[8])
    for m in range(len(vals)):
        row[cols[m]] = vals[m]
    m = len(vals)
    for leg in range(4):
        row[cols[m + leg]] = 1.0 if inp[x + X_CONTACT + leg] > 0.0 else 0.0
    m += 4
    row[cols[m]] = 1.0 if gst[S_STANCE_H] > 0.5 else 0.0
    row[cols[m + 1]] = 1.0 if gst[S_STANCE_F] > 0.5 else 0.0
    row[cols[m + 2]] = gst[S_PHASE]
    row[cols[m + 3]] = gprm[P_FREQ]
    row[cols[m + 4]] = 0.0  # a motor-rendered spine stores no spring energy
    ol = int(ws[W_LEGDQ])
    for j in range(12):
        row[cols[K_LEG_TAU + j]] = gout[j]
        row[cols[K_LEG_TAU + 12 + j]] = inp[I_JQ + nj + int(ws[ol + j])]
    return code
