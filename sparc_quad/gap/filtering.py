"""One contiguous block of a trial, zero-phase low-passed and decimated: the samples every fit uses.

ddq is the forward difference of dq (the torque held over [t_k, t_k+1) is what changed dq_k into dq_k+1),
then filtered; one sample is kept per 1/(2 f_c) (the decimation step), away from the filter's edges.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.signal import butter, sosfiltfilt

from sparc_quad.effects.plant import PlantEffects
from sparc_quad.gap.robot import Robot
from sparc_quad.gap.trial import Trial

EDGE_S = 0.15  # filter edge margin dropped at each end of a block


@dataclass
class Block:
    """One contiguous block of one trial, filtered, with decimation indices."""

    trial: Trial
    robot: Robot
    cutoff_hz: float
    step: int  # decimation step in samples
    idx: np.ndarray = field(init=False)
    sos: np.ndarray = field(init=False, repr=False)

    def __post_init__(self):
        rate = self.trial.rate_hz
        self.sos = butter(4, self.cutoff_hz, fs=rate, output="sos")
        n = len(self.trial.t)
        edge = round(EDGE_S * rate)
        idx = np.arange(0, n, self.step)
        self.idx = idx[(idx >= edge) & (idx < n - edge - 1)]
        dq = self.trial.dq
        ddq = np.vstack([np.diff(dq, axis=0) / self.trial.dt, np.zeros((1, dq.shape[1]))])
        self.dq_f = self.F(dq)
        self.ddq_f = self.F(ddq)
        # friction over a step: f(dq_k) + f'(dq_k) (dq_k+1 - dq_k) / 2, the discretisation of
        # Robot.forward_step (second order in the step, like the midpoint value, and free of chatter)
        step_dq = np.vstack([np.diff(dq, axis=0), np.zeros((1, dq.shape[1]))])
        self.dq_act_raw = dq[:, self.robot.act_idx]
        self.half_step_dq = 0.5 * step_dq[:, self.robot.act_idx]
        self.dq_mid_f = self.F(dq + 0.5 * step_dq)
        self._qcache: dict = {}

    def F(self, x: np.ndarray, decimate: bool = True) -> np.ndarray:
        y = sosfiltfilt(self.sos, x, axis=0)
        return y[self.idx] if decimate else y

    def q_f(self, plant: PlantEffects) -> np.ndarray:
        """Filtered true q (the plant's encoder offsets removed), decimated; cached per offset."""
        key = tuple(plant.enc_offset)
        if key not in self._qcache:
            q = self.trial.q.copy()
            q[:, self.robot.act_idx] = plant.true_q(q[:, self.robot.act_idx])
            self._qcache = {key: self.F(q)}
        return self._qcache[key]

    @property
    def n(self) -> int:
        return len(self.idx)
