"""Inverse-dynamics residual of a plant on a block (per joint, N*m, at the decimated samples):

    r = F(applied(tau_cmd)) + F(friction(dq)) + J^T w - rnea(q_true, dq, ddq)

with the plant's actuator chain, friction, armature, inertial changes and encoder offset."""

from __future__ import annotations

import numpy as np

from sparc_quad.effects.plant import PlantEffects
from sparc_quad.gap.filtering import Block
from sparc_quad.gap.robot import Robot


def residual(block: Block, plant: PlantEffects) -> np.ndarray:
    """Inverse-dynamics residual (n_dec, nv), N*m (see module docstring)."""
    rb = block.robot
    tr = block.trial
    model = rb.plant_model(plant)
    q = block.q_f(plant)
    tau = np.zeros((block.n, rb.nv))
    fr, slope = plant.friction_and_slope(block.dq_act_raw)
    tau[:, rb.act_idx] = block.F(plant.applied_torque_series(tr.tau_cmd, tr.dt)
                                 + fr - slope * block.half_step_dq)
    if tr.f_ext is not None:
        tau += rb.ext_torque(q, block.F(tr.f_ext))
    tau[:, rb.act_idx] -= plant.coupled_inertia_torque(block.ddq_f[:, rb.act_idx])
    return tau - Robot.rnea(model, q, block.dq_f, block.ddq_f)
