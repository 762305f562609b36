"""The spine's natural frequency f_n(k) on the quadruped, from a free-oscillation test.

The whole robot floats in zero gravity (no ground contact), legs held at their stand pose by a joint PD,
the spine a passive spring of stiffness k (no damping) at the equilibrium arch. The spine is displaced
1 cm along x and released; f_n is the mean frequency of the x oscillation from its zero crossings. Both
bodies (with their legs) move, so this is the frequency the bound can excite, not the bench's (hind body
clamped, light front body).
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from spine_module import params as P


@lru_cache(maxsize=64)
def spine_natural_frequency_hz(k_x: float, k_z: float = float(P.K_DEFAULT[1]),
                               k_theta: float = float(P.K_DEFAULT[2]), host: str = "solo12",
                               displacement_m: float = 0.01, duration_s: float = 2.0) -> float:
    """f_n (Hz) of the x mode for task stiffness (k_x N/m, k_z N/m, k_theta N*m/rad). NaN if no
    oscillation is seen (fewer than three zero crossings)."""
    from sparc_quad.sim.pybullet_quiet import pb
    from sparc_quad.sim.quadruped_world import QuadrupedWorld, WorldConfig
    from sparc_quad.sim.spine_drive import PassiveSpine, SpineGains
    from spine_module.model import SpineModel

    if not (k_x > 0 and k_z > 0 and k_theta > 0):
        raise ValueError(f"stiffnesses must be > 0, got {(k_x, k_z, k_theta)}")
    world = QuadrupedWorld(WorldConfig(host=host, gravity_m_s2=0.0, seed=0))
    try:
        c = world.client
        pos, orn = pb.getBasePositionAndOrientation(world.robot, physicsClientId=c)
        pb.resetBasePositionAndOrientation(world.robot, [pos[0], pos[1], pos[2] + 0.5], orn,
                                           physicsClientId=c)
        x0 = P.X_EQUILIBRIUM + np.array([displacement_m, 0.0, 0.0])
        q = SpineModel().inverse_kinematics(x0)
        for j, qj in zip(world.spine_idx, q[1:], strict=True):
            pb.resetJointState(world.robot, j, float(qj), 0.0, physicsClientId=c)
        world.read()
        spring = PassiveSpine(SpineGains(k=(k_x, k_z, k_theta), d=(0.0, 0.0, 0.0)), preload=False)
        hold = {k: world.leg_state(k) for k in world.legs}
        qs, dqs = np.zeros(4), np.zeros(4)
        n = round(duration_s / world.cfg.dt_s)
        xs = np.empty(n)
        for i in range(n):
            qs[1:], dqs[1:] = world.q_spine, world.dq_spine
            tau = spring.step(qs, dqs, 0.0)
            legs = {}
            for key, h in hold.items():
                st = world.leg_state(key)
                legs[key] = (20.0 * (h.haa - st.haa) - 0.5 * st.dhaa, 20.0 * (h.hfe - st.hfe) - 0.5 * st.dhfe,
                             20.0 * (h.kfe - st.kfe) - 0.5 * st.dkfe)
            world.set_torques(tau, legs)
            world.step()
            xs[i] = spring.x[0]
    finally:
        world.close()
    e = xs - P.X_EQUILIBRIUM[0]
    e -= e.mean()
    s = np.signbit(e)
    cross = np.flatnonzero(s[1:] != s[:-1])
    if len(cross) < 3:
        return float("nan")
    half_periods = np.diff(cross) * world.cfg.dt_s
    return float(1.0 / (2.0 * half_periods.mean()))
