"""The least noise floor a trial allows: what its sensors resolve and the numbers' precision.

A floor measured from the data alone collapses on clean data (an ideal plant, a joint that barely moves,
quantisation error that is constant while a signal is still): 4.7e-16 N*m was seen, against which every
residual is "unexplained". No residual can be trusted below what the sensors resolve, so the floor the gap
is judged against is never below this one. Per joint v, at the decimated samples (N*m):

    sigma_v^2 = (g0 s_tau)^2                               torque command / estimate, one frame LSB
              + sum_u mean(M_vu^2) (g2 s_dq,u)^2           velocity LSB through the derivative (q'' term)
              + sum_u mean((d tau / d q)_vu^2) (g0 s_q,u)^2  position LSB through gravity and inertia
              + mean(f'(dq)_v^2) (g0 s_dq,v)^2              velocity LSB through the plant's friction slope
              + mean(J_x,v^2) (g0 s_F)^2                   load cell, as an x force at the ee frame
              + (EPS_REL max|tau_v|)^2                      float64 precision of the residual's sums

with s = LSB / sqrt(12) (uniform quantisation error) for q, dq and tau and s_F the load cell's 1-sigma
reading error; g0 = the low-pass's white-noise gain (sqrt(sum h^2)), g2 = the same for the forward
difference of dq then the low-pass (sqrt(sum (h_k - h_k-1)^2) / dt). The sensors' numbers come from the
sidecar's `resolution` (an lcm log of the spine without a sidecar: one CyberGear frame LSB and the bench
load cell, `lcm_log.spine_resolution`); a trial without them gets only the precision term. The friction
term needs the plant's friction: with the nominal plant (before any effect is named) it is what that plant
knows; the verdict is judged against the floor of the final plant (a sharp Coulomb tanh turns one velocity
LSB into torque).
"""

from __future__ import annotations

import math

import numpy as np
from scipy.signal import sosfiltfilt

from sparc_quad.effects.plant import PlantEffects
from sparc_quad.gap.filtering import Block

# float64's relative precision (2.2e-16) times the number of rounded operations an inverse-dynamics
# residual of a short chain sums, filtered (order 1e3): the smallest residual that means anything
EPS_REL = float(np.finfo(float).eps) * 1e3
MAX_SAMPLES = 400  # the model terms are averaged over at most this many decimated samples


def filter_gains(block: Block) -> tuple[float, float]:
    """(g0, g2): white-noise gains of the block's low-pass and of (forward difference / dt, low-pass)."""
    n = 8 * block.step + int(4 * block.trial.rate_hz / block.cutoff_hz)
    imp = np.zeros(2 * n + 1)
    imp[n] = 1.0
    h = sosfiltfilt(block.sos, imp)
    return math.sqrt(float(np.sum(h**2))), math.sqrt(float(np.sum(np.diff(h) ** 2))) * block.trial.rate_hz


def resolution_floor(blocks: list[Block], plant: PlantEffects) -> tuple[np.ndarray, dict]:
    """Per-joint least floor (N*m) over the blocks, and its parts (for the report)."""
    import pinocchio as pin

    b0 = blocks[0]
    rb = b0.robot
    res = b0.trial.meta.get("resolution") or {}
    s_q = float(res.get("q_rad", 0.0)) / math.sqrt(12.0)
    s_dq = float(res.get("dq_rad_s", 0.0)) / math.sqrt(12.0)
    s_tau = float(res.get("tau_nm", 0.0)) / math.sqrt(12.0)
    s_f = float(res.get("f_ext_n", 0.0))
    model = rb.plant_model(plant)
    data = model.createData()
    q = np.vstack([b.q_f(plant) for b in blocks])
    dq = np.vstack([b.dq_f for b in blocks])
    ddq = np.vstack([b.ddq_f for b in blocks])
    pick = np.linspace(0, len(q) - 1, min(MAX_SAMPLES, len(q))).astype(int)
    m2 = np.zeros((rb.nv, rb.nv))
    g2 = np.zeros((rb.nv, rb.nv))
    for i in pick:
        M = pin.crba(model, data, q[i])
        M = np.triu(M) + np.triu(M, 1).T
        m2 += M**2
        pin.computeRNEADerivatives(model, data, q[i], dq[i], ddq[i])
        g2 += np.asarray(data.dtau_dq) ** 2
    m2 /= len(pick)
    g2 /= len(pick)
    jx2 = np.zeros(rb.nv)
    if s_f > 0 and rb.ee_frame is not None:
        unit = np.zeros((len(pick), 3))
        unit[:, 0] = 1.0
        jx2 = np.mean(rb.ext_torque(q[pick], unit) ** 2, axis=0)
    k0, k2 = filter_gains(b0)
    tau_parts = np.zeros(rb.nv)
    tau_parts[rb.act_idx] = (k0 * s_tau) ** 2
    acc = m2 @ np.full(rb.nv, (k2 * s_dq) ** 2)
    pos = g2 @ np.full(rb.nv, (k0 * s_q) ** 2)
    force = jx2 * (k0 * s_f) ** 2
    fric = np.zeros(rb.nv)
    if s_dq > 0:
        slopes = np.vstack([plant.friction_and_slope(b.dq_act_raw[b.idx])[1] for b in blocks])
        fric[rb.act_idx] = np.mean(slopes**2, axis=0) * (k0 * s_dq) ** 2
    tau_scale = np.zeros(rb.nv)
    for b in blocks:
        tau_scale[rb.act_idx] = np.maximum(tau_scale[rb.act_idx], np.max(np.abs(b.trial.tau_cmd), axis=0))
    # an unactuated joint's scale: its gravity/inertia torque, bounded below by one N*m-scale unit
    tau_scale = np.maximum(tau_scale, 1.0)
    precision = (EPS_REL * tau_scale) ** 2
    floor = np.sqrt(tau_parts + acc + pos + fric + force + precision)
    parts = {"torque_lsb": np.sqrt(tau_parts), "velocity_lsb_via_acceleration": np.sqrt(acc),
             "position_lsb": np.sqrt(pos), "velocity_lsb_via_friction": np.sqrt(fric),
             "load_cell": np.sqrt(force),
             "float64_precision": np.sqrt(precision)}
    return floor, parts
