"""Can the spine reach a task target at all? A target outside the workspace pins joints at their limits.

The per-coordinate ranges of a spine command (x in [0, 0.3614] m, z, theta in [-pi, pi]) admit targets no
joint configuration reaches: (0, 0, 0) folds the chain back through the hind body, (0.3614, 0, 0) is the
straight singular pose, (0.273, 0, pi) turns the front body over. The impedance law then pulls the joints
into their limits at full torque. `unreachable` solves the planar chain in closed form (convention of
`SpineModel.task_pose`, checked in tests: u(a) = (cos a, -sin a) in (x, z), theta = q2 + q3 + q4) and asks
for a solution with every joint at least `JOINT_LIMIT_MARGIN_RAD` inside its limits and the middle joint bent
by at least that much (out of the straight singularity, where the DLS pseudo-inverse gives no stiffness).
"""

from __future__ import annotations

import math

from spine_module import params as P

_L0, _L1, _L2, _L3 = (link.length_m for link in P.LINKS)
_LO = tuple(P.JOINT_LOWER_RAD[j] for j in P.ACTUATED_JOINTS)
_HI = tuple(P.JOINT_UPPER_RAD[j] for j in P.ACTUATED_JOINTS)
MARGIN_RAD = P.JOINT_LIMIT_MARGIN_RAD


def _wrap(a: float) -> float:
    return math.atan2(math.sin(a), math.cos(a))


def joint_solutions(x_m: float, z_m: float, theta_rad: float) -> list[tuple[float, float, float]]:
    """Both closed-form solutions (q2, q3, q4) rad for the pose, wrapped to (-pi, pi]; [] if out of reach."""
    wx = x_m - _L0 - _L3 * math.cos(theta_rad)
    wy = -(z_m + _L3 * math.sin(theta_rad))  # (x, -z): the chain's angles count counter-clockwise there
    c3 = (wx * wx + wy * wy - _L1 * _L1 - _L2 * _L2) / (2.0 * _L1 * _L2)
    if not -1.0 <= c3 <= 1.0:
        return []
    out = []
    for q3 in {math.acos(c3), -math.acos(c3)}:
        q2 = math.atan2(wy, wx) - math.atan2(_L2 * math.sin(q3), _L1 + _L2 * math.cos(q3))
        out.append((_wrap(q2), q3, _wrap(theta_rad - q2 - q3)))
    return out


def unreachable(x_m: float, z_m: float, theta_rad: float) -> str | None:
    """Why the target cannot be held (one phrase), or None when a solution lies inside the joints' ranges by
    MARGIN_RAD and bent by MARGIN_RAD at q3."""
    sols = joint_solutions(x_m, z_m, theta_rad)
    if not sols:
        return "beyond the spine's reach"
    for q in sols:
        inside = all(lo + MARGIN_RAD <= v <= hi - MARGIN_RAD for v, lo, hi in zip(q, _LO, _HI, strict=True))
        if inside and abs(q[1]) >= MARGIN_RAD:
            return None
    return (f"outside the workspace: no joint solution {MARGIN_RAD:g} rad inside the joint limits and "
            "bent away from the straight pose")


__all__ = ["MARGIN_RAD", "joint_solutions", "unreachable"]
