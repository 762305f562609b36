"""The residual part no model can explain, per joint: what the gap is measured against."""

from __future__ import annotations

import math

import numpy as np
from scipy.signal import sosfiltfilt

from sparc_quad.gap.filtering import Block

MOVING_FRACTION = 0.02  # a joint is moving where |dq| exceeds this fraction of its RMS velocity

def noise_floor(blocks: list[Block], residuals: list[np.ndarray]) -> tuple[np.ndarray, str]:
    """Per-joint RMS (N*m) of the residual part no model can explain.

    Repeated segments when the trials say their excitation has a period (`period_s`) and hold >= 2 of them:
    the spread of the residual across periods at equal phase (deterministic effects repeat, noise does
    not). Otherwise the high-frequency residual: robust scale of second differences of the decimated
    residual on the samples where the joint moves (|dq| > MOVING_FRACTION x its RMS), per joint (a rough
    bound that includes fast model errors).
    """
    per_sum, per_cnt = None, 0
    for b, r in zip(blocks, residuals, strict=True):
        period = b.trial.meta.get("period_s")
        if not period:
            continue
        P = round(period * b.trial.rate_hz)
        if P % b.step:
            continue
        phase = b.idx % P
        cyc = b.idx // P
        if cyc.max() - cyc.min() < 1:
            continue
        for ph in np.unique(phase):
            sel = phase == ph
            if sel.sum() >= 2:
                v = np.var(r[sel], axis=0, ddof=1)
                per_sum = v * (sel.sum() - 1) if per_sum is None else per_sum + v * (sel.sum() - 1)
                per_cnt += sel.sum() - 1
    if per_sum is not None and per_cnt >= 20:
        return np.sqrt(per_sum / per_cnt), "repeated_segments"
    d2 = np.vstack([np.diff(r, n=2, axis=0) for r in residuals])
    # moving samples only (a joint at rest holds its residual still: a floor from rest collapses to ~0)
    dq = np.vstack([b.dq_f[1:-1] for b in blocks])
    moving = np.abs(dq) > MOVING_FRACTION * np.sqrt(np.mean(dq**2, axis=0))
    mad = np.empty(d2.shape[1])
    for v in range(d2.shape[1]):
        x = d2[moving[:, v], v] if moving[:, v].sum() >= 20 else d2[:, v]
        mad[v] = np.median(np.abs(x - np.median(x))) * 1.4826
    # var(second difference) = sigma^2 (6 - 8 rho1 + 2 rho2), rho_k: the correlation the low-pass leaves
    # between decimated samples of white noise (the residual noise of the synthetic bench matches it)
    rho1, rho2 = filtered_white_correlation(blocks[0])
    return mad / math.sqrt(6.0 - 8.0 * rho1 + 2.0 * rho2), "high_frequency_residual"


def filtered_white_correlation(block: Block) -> tuple[float, float]:
    n = 8 * block.step + int(4 * block.trial.rate_hz / block.cutoff_hz)
    imp = np.zeros(2 * n + 1)
    imp[n] = 1.0
    h = sosfiltfilt(block.sos, imp)
    def rho(lag):
        return float(np.dot(h[:-lag], h[lag:]) / np.dot(h, h))
    return rho(block.step), rho(2 * block.step)
