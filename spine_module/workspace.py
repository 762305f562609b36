"""Can the spine reach a task target at all? A target outside the workspace pins joints at their limits.

The per-coordinate ranges of a spine command (x in [0, 0.3614] m, z, theta in [-pi, pi]) admit targets no
joint configuration reaches: (0, 0, 0) folds the chain back through the hind body, (0.3614, 0, 0) is the
straight singular pose, (0.273, 0, pi) turns the front body over. The impedance law then pulls the joints
into their limits at full torque. `unreachable` solves the planar chain in closed form (convention of
`SpineModel.task_pose`, checked in tests: u(a) = (cos a, -sin a) in (x, z), theta = q2 + q3 + q4) and asks
for a solution with every joint at least `JOINT_LIMIT_MARGIN_RAD` inside its limits and the middle joint bent
by at least that much (out of the straight singularity, where the DLS pseudo-inverse gives no stiffness).
`Workspace.of(spine)` is the same for another spine (another host's links and joint ranges); the module's
functions are the SPARC module's.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from spine_module import params as P

MARGIN_RAD = P.JOINT_LIMIT_MARGIN_RAD


def _wrap(a: float) -> float:
    return math.atan2(math.sin(a), math.cos(a))


@dataclass(frozen=True)
class Workspace:
    """The targets one spine can hold: its four link lengths (m) and its actuated joints' ranges (rad).
    A node checks commands against the workspace of the spine model it runs (`of`), so a host whose spine
    differs from the SPARC module's (the spined dog's) is judged by its own links and limits."""

    lengths_m: tuple[float, float, float, float]
    lower_rad: tuple[float, float, float]
    upper_rad: tuple[float, float, float]
    margin_rad: float = MARGIN_RAD

    @classmethod
    def of(cls, spine: P.SpineParams = P.DEFAULT_SPINE) -> Workspace:
        lengths = tuple(link.length_m for link in spine.links)
        if len(lengths) != 4:
            raise ValueError(f"a spine workspace needs four links (hind body, two spine links, front body), "
                             f"got {len(lengths)}")
        return cls(lengths, tuple(spine.lower_rad[j] for j in P.ACTUATED_JOINTS),  # type: ignore[arg-type]
                   tuple(spine.upper_rad[j] for j in P.ACTUATED_JOINTS))

    @property
    def reach_m(self) -> float:
        """Task x of the straight spine, m: no target lies farther from the hind body's joint."""
        return sum(self.lengths_m)

    def joint_solutions(self, x_m: float, z_m: float, theta_rad: float) -> list[tuple[float, float, float]]:
        """Both closed-form solutions (q2, q3, q4) rad for the pose, wrapped to (-pi, pi]; [] if out of
        reach."""
        l0, l1, l2, l3 = self.lengths_m
        wx = x_m - l0 - l3 * math.cos(theta_rad)
        wy = -(z_m + l3 * math.sin(theta_rad))  # (x, -z): the chain's angles count counter-clockwise there
        c3 = (wx * wx + wy * wy - l1 * l1 - l2 * l2) / (2.0 * l1 * l2)
        if not -1.0 <= c3 <= 1.0:
            return []
        out = []
        for q3 in {math.acos(c3), -math.acos(c3)}:
            q2 = math.atan2(wy, wx) - math.atan2(l2 * math.sin(q3), l1 + l2 * math.cos(q3))
            out.append((_wrap(q2), q3, _wrap(theta_rad - q2 - q3)))
        return out

    def unreachable(self, x_m: float, z_m: float, theta_rad: float) -> str | None:
        """Why the target cannot be held (one phrase), or None when a solution lies inside the joints'
        ranges by `margin_rad` and bent by `margin_rad` at q3."""
        sols = self.joint_solutions(x_m, z_m, theta_rad)
        if not sols:
            return "beyond the spine's reach"
        m = self.margin_rad
        for q in sols:
            inside = all(lo + m <= v <= hi - m for v, lo, hi in zip(q, self.lower_rad, self.upper_rad,
                                                                   strict=True))
            if inside and abs(q[1]) >= m:
                return None
        return (f"outside the workspace: no joint solution {m:g} rad inside the joint limits and "
                "bent away from the straight pose")


SPARC = Workspace.of()  # the SPARC module's spine (Table III): what the message codec checks by default
joint_solutions = SPARC.joint_solutions
unreachable = SPARC.unreachable

__all__ = ["MARGIN_RAD", "SPARC", "Workspace", "joint_solutions", "unreachable"]
