"""`safety.limit_torque`, the output stage the node and the simulated direct spine share, equals the paths
it replaced bit for bit: the node's (`joint_limit_damping_list` added when a joint is near a limit, then
`clamp_torque_list`) and the direct spine's copy of it (which added the zero-depth damping -c*0*dq as well:
the same floats for finite rates, up to the sign of a zero torque)."""

from __future__ import annotations

import math
import struct

import numpy as np
import pytest

from spine_module import safety
from spine_module.safety import (
    TorqueLimits,
    clamp_torque_list,
    joint_limit_damping_list,
    limit_torque,
)

CFG = safety.SafetyConfig()
LIM = TorqueLimits.from_config(CFG)
LOWER, UPPER = CFG.lower.tolist(), CFG.upper.tolist()


def _node_before(tau, q, dq, lower=LOWER, upper=UPPER, margin=CFG.limit_margin, c=CFG.joint_limit_damping,
                 limit=CFG.torque_limit):
    """SpineNode.tick's output stage as it was written before `limit_torque`."""
    extra, near = joint_limit_damping_list(list(q), list(dq), lower, upper, margin, c)
    tau = list(tau)
    if any(near):
        tau = [a + b for a, b in zip(tau, extra, strict=True)]
    tau, sat = clamp_torque_list(tau, limit)
    return tau, any(near), any(sat)


def _direct_before(tau, q, dq, lower=LOWER, upper=UPPER, margin=CFG.limit_margin, c=CFG.joint_limit_damping,
                   limit=CFG.torque_limit):
    """DirectSpine._node_limits as it was written before `limit_torque`."""
    clear = [(lo + margin, hi - margin) for lo, hi in zip(lower, upper, strict=True)] if margin > 0 else None
    qa, qb, qc = q
    if (clear is not None and clear[0][0] <= qa <= clear[0][1] and clear[1][0] <= qb <= clear[1][1]
            and clear[2][0] <= qc <= clear[2][1]):
        z = -c * 0.0
        da, db, dc = dq
        a, b, cc = tau[0] + z * da, tau[1] + z * db, tau[2] + z * dc
    else:
        (ea, eb, ec), _ = joint_limit_damping_list([float(qa), float(qb), float(qc)], [float(v) for v in dq],
                                                   lower, upper, margin, c)
        a, b, cc = tau[0] + ea, tau[1] + eb, tau[2] + ec
    if -limit <= a <= limit and -limit <= b <= limit and -limit <= cc <= limit:
        return [a, b, cc]
    out, _ = clamp_torque_list([a, b, cc], limit)
    return out


def _bits(v) -> bytes:
    return struct.pack("3d", *v)


def _cases(rng: np.random.Generator, n: int):
    lo, hi, m = np.array(LOWER), np.array(UPPER), CFG.limit_margin
    lim = CFG.torque_limit
    for k in range(n):
        # per joint: mid-range, inside the margin, beyond the limit, anywhere
        where = rng.choice(4, 3, p=[0.8, 0.1, 0.04, 0.06])
        q = np.where(where == 0, rng.uniform(lo + m, hi - m),
                     np.where(where == 1, np.where(rng.random(3) < 0.5, rng.uniform(lo, lo + m),
                                                   rng.uniform(hi - m, hi)),
                              np.where(where == 2, np.where(rng.random(3) < 0.5, lo - rng.random(3),
                                                            hi + rng.random(3)),
                                       rng.uniform(lo - 1, hi + 1))))
        dq = rng.normal(0.0, 5.0, 3) * (rng.random(3) < 0.9)
        tau = rng.normal(0.0, 0.8 * lim, 3)
        if k % 7 == 0:
            tau[rng.integers(0, 3)] = rng.choice([np.nan, np.inf, -np.inf, 2 * lim, -lim, lim])
        if k % 11 == 0:  # a joint exactly on the margin's edge
            j = rng.integers(0, 3)
            q[j] = (hi[j] - m) if rng.random() < 0.5 else (lo[j] + m)
        yield tau.tolist(), q.tolist(), dq.tolist()


def test_limit_torque_is_the_node_path_bit_for_bit():
    rng = np.random.default_rng(7)
    seen = {"near": 0, "clamped": 0, "plain": 0}
    for tau, q, dq in _cases(rng, 4000):
        got = limit_torque(tau, q, dq, LIM)
        ref, near, clamped = _node_before(tau, q, dq)
        assert _bits(got[:3]) == _bits(ref), (tau, q, dq)
        assert got[3:] == (near, clamped), (tau, q, dq)
        seen["near"] += near
        seen["clamped"] += clamped
        seen["plain"] += not (near or clamped)
    assert min(seen.values()) > 200, seen  # every branch exercised


def test_limit_torque_is_the_direct_path_for_finite_rates():
    rng = np.random.default_rng(8)
    for tau, q, dq in _cases(rng, 4000):
        got = limit_torque(tau, q, dq, LIM)[:3]
        assert _bits(got) == _bits(_direct_before(tau, q, dq)), (tau, q, dq)
    # what differs: the old path's -c*0*dq turned a -0.0 controller torque into +0.0 (dq < 0)
    q_mid = [(lo + hi) / 2 for lo, hi in zip(LOWER, UPPER, strict=True)]
    assert _direct_before([-0.0, 1.0, 1.0], q_mid, [-1.0, 0.0, 0.0])[0] == 0.0
    assert math.copysign(1.0, limit_torque([-0.0, 1.0, 1.0], q_mid, [-1.0, 0.0, 0.0], LIM)[0]) == -1.0


@pytest.mark.parametrize("margin", [0.0, -0.01])
def test_no_margin_takes_the_full_path(margin):
    """Without a positive margin there is no shortcut (as `joint_limit_damping_list`'s own)."""
    lim = TorqueLimits.of(LOWER, UPPER, margin, CFG.joint_limit_damping, CFG.torque_limit)
    assert lim.clear is None
    q = [(lo + hi) / 2 for lo, hi in zip(LOWER, UPPER, strict=True)]
    if margin == 0.0:
        with pytest.raises(ZeroDivisionError):  # the full path divides by the margin, as it always did
            limit_torque([1.0, 1.0, 1.0], q, [0.1, 0.1, 0.1], lim)
    else:
        got = limit_torque([1.0, 1.0, 1.0], q, [0.1, 0.1, 0.1], lim)
        ref, near, clamped = _node_before([1.0, 1.0, 1.0], q, [0.1, 0.1, 0.1], margin=margin)
        assert _bits(got[:3]) == _bits(ref) and got[3:] == (near, clamped)


def test_limits_need_three_joints():
    with pytest.raises(ValueError, match="3 joints"):
        TorqueLimits.of([0.0, 0.0], [1.0, 1.0], 0.1, 1.0, 12.0)
