"""Windowed replay: the model driven by the recorded commanded torques, re-initialised from the measured
state at the start of each window (pinocchio, the plant's armature, payloads,
actuator chain and friction, `Robot.forward_step` at the log rate, torque held over each sample).

A joint that moves no inertia in the plant (a massless distal link without a rotor inertia) cannot be
integrated: it follows its measured motion, is listed in "not_replayed", and its RMS is NaN."""

from __future__ import annotations

import numpy as np

from sparc_quad.effects.plant import PlantEffects
from sparc_quad.gap.robot import Robot
from sparc_quad.gap.trial import Trial


def replay(trial: Trial, robot: Robot, plant: PlantEffects, window_s: float = 0.2) -> dict:
    """Returns {"q_sim": (N, nv) array, "rms_rad": per-joint RMS error over all windows,
    "window_rms": (n_windows, nv) array, "window_t0": (n_windows,) start times, "not_replayed": names}."""
    model = robot.plant_model(plant)
    data = model.createData()
    dt = trial.dt
    n = len(trial.t)
    w = max(2, round(window_s / dt))
    act = robot.act_idx
    arm = np.zeros(robot.nv)
    arm[act] = plant.armature() + np.diag(plant.coupled_M)
    stuck = robot.massless_joints(arm)
    pres = np.array([robot.joints.index(j) for j in stuck], dtype=int)
    ddq_meas = np.vstack([np.diff(trial.dq, axis=0) / dt, np.zeros((1, robot.nv))])
    applied = plant.applied_torque_series(trial.tau_cmd, dt)
    q_meas = trial.q.copy()
    q_meas[:, act] = plant.true_q(q_meas[:, act])
    q_sim = np.empty_like(q_meas)
    ext = robot.ext_torque(q_meas, trial.f_ext) if trial.f_ext is not None else None
    tau = np.zeros(robot.nv)
    win_rms, starts = [], []
    lo, hi = robot.lower, robot.upper
    dq_max = 10.0 * np.max(np.abs(trial.dq), axis=0) + 1.0  # a diverging window stays finite (and large)
    for s in range(0, n - 1, w):
        e = min(s + w, n)
        q, dq = q_meas[s].copy(), trial.dq[s].copy()
        for k in range(s, e):
            if pres.size:
                q[pres], dq[pres] = q_meas[k, pres], trial.dq[k, pres]
            q_sim[k] = q
            tau[:] = 0.0
            tau[act] = applied[k]
            if ext is not None:
                tau += ext[k]
            q, dq = robot.forward_step(model, data, q, dq, tau, plant, dt, pres, ddq_meas[k, pres])
            q = np.clip(q, lo - 1.0, hi + 1.0)
            dq = np.clip(dq, -dq_max, dq_max)
        err = q_sim[s:e] - q_meas[s:e]
        win_rms.append(np.sqrt(np.mean(err**2, axis=0)))
        starts.append(trial.t[s])
    q_sim[n - 1] = q_sim[n - 2]
    win = np.array(win_rms)
    win[:, pres] = np.nan
    return {"q_sim": q_sim, "q_meas": q_meas, "window_rms": win, "window_t0": np.array(starts),
            "rms_rad": np.sqrt(np.mean(win**2, axis=0)), "not_replayed": stuck}
