"""The closed loop of a bench experiment: controller on measured state, plant, and what pushes on it.

One `run` call is one trial: deterministic for its seed, no side effects, returns its log.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from sparc_quad.sim.bench_world import BenchWorld
from sparc_quad.sim.plant import PlantConfig
from spine_module import params as P
from spine_module.control import ImpedanceController, StribeckFriction, TaskController, TaskPDController
from spine_module.model import SpineModel

# external force along x (N) as a function of (time s, true task pose, true task velocity)
ForceLaw = Callable[[float, np.ndarray, np.ndarray], float]


@dataclass
class TrialLog:
    """Sampled trial: time (s), true and encoder-based task pose (m, m, rad), applied F_x and load cell
    reading (N), commanded torques (N*m)."""

    t: np.ndarray
    x_true: np.ndarray
    x_meas: np.ndarray
    f_true: np.ndarray
    f_cell: np.ndarray
    tau: np.ndarray


def make_controller(kind: str, model: SpineModel, k: tuple[float, float, float],
                    d: tuple[float, float, float], friction_compensation: bool = True) -> TaskController:
    """'impedance' (eq. 3 + eq. 4 when friction_compensation) or 'pd' (eq. 5)."""
    if kind == "impedance":
        fr = StribeckFriction.nominal() if friction_compensation else None
        return ImpedanceController(model, friction=fr, k=k, d=d)
    if kind == "pd":
        return TaskPDController(model, k=k, d=d)
    raise ValueError(f"unknown controller {kind!r}; use 'impedance' or 'pd'")


def run(controller: TaskController, duration_s: float, force: ForceLaw | None = None,
        q0: np.ndarray | None = None, plant: PlantConfig | None = None, seed: int = 0,
        sample_every: int = 1) -> TrialLog:
    """Run the bench for duration_s with `controller` at 1 kHz; log every `sample_every` steps."""
    n = round(duration_s / P.CONTROL_PERIOD_S)
    m = n // sample_every
    log = TrialLog(np.zeros(m), np.zeros((m, 3)), np.zeros((m, 3)), np.zeros(m), np.zeros(m),
                   np.zeros((m, 3)))
    model = controller.model
    kin = model.create_data()
    f_ext = np.zeros(3)
    with BenchWorld(plant=plant, seed=seed, q0=q0) as world:
        row = 0
        for i in range(n):
            q, dq = world.measured_joint_state()
            out = controller.step(q, dq)
            st = world.state()
            model.update_kinematics(kin, st.q, st.dq)
            fx = force(world.time_s, kin.x, kin.dx) if force is not None else 0.0
            f_ext[0] = fx
            if i % sample_every == 0 and row < m:
                log.t[row] = world.time_s
                log.x_true[row] = kin.x
                log.x_meas[row] = out.x
                log.f_true[row] = fx
                log.f_cell[row] = world.load_cell(fx)
                log.tau[row] = out.tau
                row += 1
            world.step(out.tau, f_ext if fx != 0.0 else None)
    return log
