"""What the robot side drives: the `Body` protocol and its three implementations.

- `BenchBody`: the pybullet bench spine (`sim.bench_world.BenchWorld`) with the rig's push and load cell;
- `QuadBody`: the quadruped's spine inside `run_bound`, which steps the world itself (the body holds the
  state of this tick and hands back the torques);
- `EmulatedCyberGears`: the bench spine behind emulated CyberGears on a CAN bus; the motors (their
  firmware's motor law and lockstep stepping) are the emulator's, so the loop neither computes torque nor
  steps.

No pybullet import here: worlds are passed in.
"""

from __future__ import annotations

from typing import Protocol

import numpy as np

from sparc_quad.robot_side.scripts import ForceLaw
from spine_module.messages import TorsoState
from spine_module.messages.motor import MotorFeedback


class Body(Protocol):
    """A robot's body as the robot side sees it. `quantise`: whether the loop must quantise its feedback
    to the frame's LSBs (False when the body's own sensor model does);
    `motors_on_bus`: the motors are emulated behind a bus (feedback and stepping are theirs)."""

    dt_s: float
    quantise: bool
    motors_on_bus: bool

    def torso(self) -> TorsoState:
        """The torso estimator's output for this tick (stamp and seq are the loop's)."""

    def feedback(self) -> MotorFeedback | None:
        """What the motors measure this tick (before frame quantisation); None when on a bus."""

    def joint_state(self) -> tuple[np.ndarray, np.ndarray]:
        """The spine joints' q2..q4 (rad) and velocities (rad/s) the motors' law acts on."""

    def step(self, tau_nm: np.ndarray) -> None:
        """Apply the motors' torques (N*m) for one tick."""

    def record(self, log) -> None:
        """Append this tick's body-specific columns to the robot log."""


class BenchBody:
    """The bench world plus the rig: push `force` at the end effector, read it with the load cell."""

    quantise = False  # the world's sensor model quantises (or not: the ideal plant)
    motors_on_bus = False

    def __init__(self, world, force: ForceLaw | None = None, load_cell_every: int = 1) -> None:
        self.world = world
        self.force = force
        self.load_cell_every = load_cell_every  # read (and draw its noise) every this many ticks, else NaN
        self._k = 0
        self.dt_s = world.dt_s
        self._kin = world.model.create_data()
        self._f_ext = np.zeros(3)
        self._tick: tuple[np.ndarray, np.ndarray, float, float] | None = None

    def torso(self) -> TorsoState:
        st = self.world.state()
        return TorsoState(q1=float(st.q[0]), dq1=float(st.dq[0]))

    def feedback(self) -> MotorFeedback:
        # as the rig: the motors' frame, then the push and its load cell (the same rng order)
        fb = self.world.feedback()
        st = self.world.state()
        self.world.model.update_kinematics(self._kin, st.q, st.dq)
        fx = float(self.force(self.world.time_s, self._kin.x, self._kin.dx)) if self.force else 0.0
        f_cell = self.world.load_cell(fx) if self._k % self.load_cell_every == 0 else np.nan
        fb.load_cell_n = np.array([f_cell, np.nan])
        self._tick = (self.world.time_s, st.q.copy(), self._kin.x.copy(), fx, f_cell)
        return fb

    def joint_state(self) -> tuple[np.ndarray, np.ndarray]:
        st = self.world.state()
        return st.q[1:], st.dq[1:]

    def step(self, tau_nm: np.ndarray) -> None:
        fx = self._tick[3]
        self._f_ext[0] = fx
        self.world.step(tau_nm, self._f_ext if fx != 0.0 else None)
        self._k += 1

    def record(self, log) -> None:
        t_world, q, x, fx, f_cell = self._tick
        log.add(t_world=t_world, q=q, x=x, f_true=fx, f_cell=f_cell, tau=self.world.last_applied.copy())


class QuadBody:
    """The quadruped's spine for one `run_bound` tick: `set` the estimator output and spine joint state,
    tick the robot side, read `tau`; `run_bound` steps the world."""

    quantise = True
    motors_on_bus = False

    def __init__(self, dt_s: float) -> None:
        self.dt_s = dt_s
        self.tau = np.zeros(3)
        self.q = np.zeros(3)
        self.dq = np.zeros(3)
        self._torso = TorsoState(ddq1_valid=True)

    def set(self, est, q_spine, dq_spine) -> None:
        """The estimate as the torso state: q̈1 always valid; the base acceleration valid when the estimate
        has one (`EstimatorOutput.base_accel`, WorldConfig.base_motion other than "fixed")."""
        acc = est.base_accel
        t = TorsoState(q1=float(est.q1), dq1=float(est.dq1), ddq1=float(est.ddq1), ddq1_valid=True)
        if acc is not None:
            t.base_accel, t.base_accel_valid = np.array(acc, dtype=float), True
        self._torso = t
        self.q[:] = q_spine
        self.dq[:] = dq_spine

    def torso(self) -> TorsoState:
        return self._torso

    # per-tick constants of the frame, copied (not built: np.full/np.zeros cost more than a copy)
    _TEMPERATURE_C = np.full(3, 30.0)
    _RUNNING = np.full(3, 2, dtype=np.int32)
    _NO_FAULT = np.zeros(3, dtype=np.int32)
    _NO_LOAD_CELL = np.full(2, np.nan)

    def feedback(self) -> MotorFeedback:
        return MotorFeedback(q=self.q.copy(), dq=self.dq.copy(), tau=self.tau.copy(),
                             temperature_c=self._TEMPERATURE_C.copy(), mode=self._RUNNING.copy(),
                             fault=self._NO_FAULT.copy(), load_cell_n=self._NO_LOAD_CELL.copy())

    def joint_state(self) -> tuple[np.ndarray, np.ndarray]:
        return self.q, self.dq

    def step(self, tau_nm: np.ndarray) -> None:
        self.tau[:] = tau_nm

    def record(self, log) -> None:
        log.add(sent_q1=self._torso.q1)


class EmulatedCyberGears:
    """The bench spine behind emulated CyberGears (`sim.cybergear_bench.BenchCoupling` as the emulator's
    load): the emulator steps the world in lockstep when every motor has had its frame."""

    quantise = False
    motors_on_bus = True

    def __init__(self, coupling) -> None:
        self.coupling = coupling
        self.dt_s = coupling.world.dt_s

    def torso(self) -> TorsoState:
        q1, dq1 = self.coupling.q1()
        return TorsoState(q1=q1, dq1=dq1)

    def feedback(self) -> None:
        return None

    def joint_state(self) -> tuple[np.ndarray, np.ndarray]:
        st = self.coupling.world.state()
        return st.q[1:], st.dq[1:]

    def step(self, tau_nm: np.ndarray) -> None:
        pass  # the emulator stepped the world when the node's frames arrived

    def record(self, log) -> None:
        pass
