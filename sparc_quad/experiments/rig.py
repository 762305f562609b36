"""The closed loop of a bench experiment: controller on measured state, plant, and what pushes on it.

One `run` call is one trial: deterministic for its seed, no side effects, returns its log. It is the robot
side's loop (`RobotSide`) with the bench world as its body and the controller in place of the node
(`DirectPort`): the same schedule, motor model and feedback frames as the node runs.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from sparc_quad.robot_side.bodies import BenchBody
from sparc_quad.robot_side.loop import RobotSide
from sparc_quad.robot_side.ports import DirectPort
from sparc_quad.sim.bench_world import BenchWorld
from sparc_quad.sim.forces import ForceLaw
from sparc_quad.sim.plant import PlantConfig
from spine_module import params as P
from spine_module.control import ImpedanceController, StribeckFriction, TaskController, TaskPDController
from spine_module.model import SpineModel

__all__ = ["QUASI_STATIC_D", "BenchConfig", "ForceLaw", "TrialLog", "make_controller", "run"]

# task damping of the quasi-static experiments (push-pull, PD): d_x N*s/m, then the defaults' d_z, d_theta
QUASI_STATIC_D: tuple[float, float, float] = (P.BENCH_QUASI_STATIC_D_X_N_S_M,
                                              *(float(v) for v in P.D_DEFAULT[1:]))


@dataclass(frozen=True)
class BenchConfig:
    """What every bench experiment shares: the stiffness of the axes it does not study (k_z N/m, k_theta
    N*m/rad), the seed of its trials and the plant (the simulated truth the controller does not know)."""

    k_z: float = float(P.K_DEFAULT[1])
    k_theta: float = float(P.K_DEFAULT[2])
    seed: int = 0
    plant: PlantConfig = field(default_factory=PlantConfig)


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
    port = DirectPort(controller)
    with BenchWorld(plant=plant, seed=seed, q0=q0) as world:
        robot = RobotSide(BenchBody(world, force, load_cell_every=sample_every), port)
        robot.run_lockstep(n)
    a = robot.log.arrays()
    rows = slice(0, m * sample_every, sample_every)
    return TrialLog(t=a["t_world"][rows], x_true=a["x"][rows], x_meas=np.array(port.x_meas)[rows],
                    f_true=a["f_true"][rows], f_cell=a["f_cell"][rows], tau=np.array(port.tau_cmd)[rows])
