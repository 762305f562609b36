"""The paper's test bench in pybullet: hind body fixed (q1 held), end effector floating, 1 kHz.

pybullet integrates the rigid chain. What it lacks is filled in here, at the joints:
- reflected rotor inertia A: pybullet has no armature;
- friction: the plant's own Stribeck law (eq. 4 with the plant's true parameters), integrated
  linearly-implicitly so that a sharp tanh stays stable at 1 kHz.
Both enter through the joint acceleration: q̈ = (M + A + dt F')⁻¹ (τ + Jᵀ F_ext − h − f(q̇)), with
F' = ∂f/∂q̇ ≥ 0, and pybullet is handed τ' = M q̈ + h, which makes its own step reproduce that q̈ exactly
(M, h from pinocchio on the same URDF; they agree with pybullet's to machine precision).
- sensing: q and q̇ quantised as CyberGear feedback frames, torque estimate with current-sensor noise, a
  load cell with its noise.
External forces are applied at the end effector as joint torques Jᵀ F (F = (F_x N, F_z N, M_y N*m) in the
hind-body frame).
"""

from __future__ import annotations

import copy
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from sparc_quad.effects.plant import PlantEffects
from sparc_quad.robots import spine_urdf_path
from sparc_quad.sim.plant import PlantConfig
from sparc_quad.sim.pybullet_quiet import pb as p
from spine_module import params as P
from spine_module.buses.base import MotorFeedback
from spine_module.control.friction import StribeckFriction
from spine_module.model import SpineModel


@dataclass
class BenchState:
    """True joint state (q1..q4) of the simulated chain."""

    q: np.ndarray
    dq: np.ndarray


class BenchWorld:
    """One pybullet client holding the bench spine. Deterministic for a given seed."""

    def __init__(self, plant: PlantConfig | None = None, seed: int = 0, dt_s: float = P.CONTROL_PERIOD_S,
                 q0: np.ndarray | None = None, effects: PlantEffects | None = None) -> None:
        effects = effects if effects is not None else (plant.effects if plant is not None else None)
        effects = copy.deepcopy(effects)  # it holds a delay line: each world gets its own
        if effects is not None:  # gap plant effects: check before any resource is taken
            if list(effects.joints) != list(P.ACTUATED_JOINTS):
                raise ValueError(f"plant-effects joints {effects.joints} != {list(P.ACTUATED_JOINTS)}")
            if effects.model_effects():
                names = sorted({e.name for e in effects.model_effects()})
                raise ValueError(f"{', '.join(names)} not supported by the pybullet bench (put it in the "
                                 "URDF)")
        self.plant = plant or PlantConfig()
        self.dt_s = dt_s
        self.rng = np.random.default_rng(seed)
        self.client = p.connect(p.DIRECT)
        p.setGravity(0, 0, -P.GRAVITY_M_S2, physicsClientId=self.client)
        p.setTimeStep(dt_s, physicsClientId=self.client)
        p.setPhysicsEngineParameter(numSolverIterations=50, physicsClientId=self.client)
        self.body = p.loadURDF(str(spine_urdf_path()), useFixedBase=True,
                               flags=p.URDF_USE_INERTIA_FROM_FILE, physicsClientId=self.client)
        self.joints = [0, 1, 2, 3]  # q1..q4 in URDF order
        self.actuated = [1, 2, 3]
        for j in self.joints:
            p.changeDynamics(self.body, j, linearDamping=0, angularDamping=0, jointDamping=0,
                             physicsClientId=self.client)
        p.changeDynamics(self.body, -1, linearDamping=0, angularDamping=0, physicsClientId=self.client)
        for link in range(p.getNumJoints(self.body, physicsClientId=self.client)):
            p.changeDynamics(self.body, link, linearDamping=0, angularDamping=0, physicsClientId=self.client)
        # the plant's own dynamics model (same URDF) for the armature transform and Jᵀ F
        self.model = SpineModel(P.SpineParams(armature_kg_m2=0.0))
        self.mdata = self.model.create_data()
        self.armature = np.full(3, self.plant.armature_kg_m2)
        self.friction = StribeckFriction([self.plant.friction] * 3)
        # --- gap workflow plant effects (`--plant FILE`, sparc_quad/effects/plant.py) -------------
        self.effects = effects
        if effects is not None:
            effects.reset(dt_s)
            self.armature = self.armature + effects.armature()
        # ------------------------------------------------------------------------------------------
        self.time_s = 0.0
        self.q1_target = 0.0
        self.last_applied = np.zeros(3)
        self.reset(P.Q_EQUILIBRIUM if q0 is None else q0)

    # --- state ---------------------------------------------------------------------------------------
    def reset(self, q: np.ndarray, dq: np.ndarray | None = None) -> None:
        dq = np.zeros(4) if dq is None else dq
        for i, j in enumerate(self.joints):
            p.resetJointState(self.body, j, float(q[i]), float(dq[i]), physicsClientId=self.client)
        self.q1_target = float(q[0])
        # q1 held by a stiff position motor (the bench clamp); actuated joints: default motors off
        p.setJointMotorControl2(self.body, 0, p.POSITION_CONTROL, targetPosition=self.q1_target,
                                force=1e4, physicsClientId=self.client)
        p.setJointMotorControlArray(self.body, self.actuated, p.VELOCITY_CONTROL, targetVelocities=[0.0] * 3,
                                    forces=[0.0] * 3, physicsClientId=self.client)

    def state(self) -> BenchState:
        states = p.getJointStates(self.body, self.joints, physicsClientId=self.client)
        return BenchState(np.array([s[0] for s in states]), np.array([s[1] for s in states]))

    def task_pose(self) -> np.ndarray:
        return self.model.task_pose(self.state().q, self.mdata)

    # --- physics ---------------------------------------------------------------------------------------
    def step(self, tau_cmd: np.ndarray, f_ext: np.ndarray | None = None) -> None:
        """Advance one time step with motor torques tau_cmd (q2..q4, N*m) and an end-effector wrench."""
        st = self.state()
        tau = np.asarray(tau_cmd, dtype=float)
        dq = st.dq[1:]
        slope = np.maximum(self.friction.slope(dq), 0.0)
        extra = 0.0
        if self.effects is not None:  # gap plant effects: actuator chain and extra friction
            tau = self.effects.applied_torque(tau)
            extra = self.effects.friction_torque(dq)
            slope = slope + np.maximum(self.effects.friction_slope(dq), 0.0)
        tau = np.clip(tau, -P.TORQUE_LIMIT_NM, P.TORQUE_LIMIT_NM)
        self.last_applied = tau.copy()
        gen = tau - self.friction.torque(dq) + extra
        if f_ext is not None:
            self.model.update_kinematics(self.mdata, st.q, st.dq)
            gen += (self.mdata.J.T @ np.asarray(f_ext, dtype=float))[1:]
        # q1 is clamped (q̈1 = 0), so the actuated rows decouple from it
        M = pin.crba(self.model.model, self.mdata.dyn, st.q)[1:, 1:]
        h = self.model.rnea(self.mdata, st.q, st.dq, self.mdata.zero_v)[1:]
        # friction at the step's midpoint velocity, f(dq + dt ddq / 2) ~ f(dq) + f'(dq) dt/2 ddq: second order
        # and A-stable (the full dt, backward Euler, dissipated more than the friction law over a step: its
        # own friction then left 2.2x and 3.8x the noise floor in an identification from its log)
        M_eff = M + np.diag(self.armature + 0.5 * self.dt_s * slope)
        ddq = np.linalg.solve(M_eff, gen - h)
        p.setJointMotorControlArray(self.body, self.actuated, p.TORQUE_CONTROL, forces=(M @ ddq + h).tolist(),
                                    physicsClientId=self.client)
        p.stepSimulation(physicsClientId=self.client)
        self.time_s += self.dt_s

    # --- sensing -------------------------------------------------------------------------------------
    def _quantise(self, x: np.ndarray, lsb: float) -> np.ndarray:
        return np.round(x / lsb) * lsb if self.plant.quantise else x

    def feedback(self) -> MotorFeedback:
        """What the three motors report: quantised angle and velocity, noisy torque estimate."""
        st = self.state()
        s = self.plant.sensors
        tau = self.last_applied.copy()
        if self.plant.noise:
            tau += self.rng.normal(0.0, s.torque_noise_nm, 3)
        q_meas = st.q[1:] if self.effects is None else self.effects.measured_q(st.q[1:])
        return MotorFeedback(q=self._quantise(q_meas, s.position_lsb_rad),
                             dq=self._quantise(st.dq[1:], s.velocity_lsb_rad_s),
                             tau=self._quantise(tau, s.torque_lsb_nm),
                             temperature_c=np.full(3, 30.0), mode=np.full(3, 2, dtype=np.int32),
                             stamp_s=self.time_s)

    def measured_joint_state(self) -> tuple[np.ndarray, np.ndarray]:
        """Controller input (q, dq) for all four joints: q1 = 0 on the bench, q2..q4 from the motors."""
        fb = self.feedback()
        st = self.state()
        return np.concatenate(([st.q[0]], fb.q)), np.concatenate(([st.dq[0]], fb.dq))

    def load_cell(self, force_n: float) -> float:
        """The load cell's reading of a true force (N)."""
        if self.plant.noise:
            return float(force_n + self.rng.normal(0.0, self.plant.sensors.load_cell_noise_n))
        return float(force_n)

    def close(self) -> None:
        if p.isConnected(self.client):
            p.disconnect(self.client)

    def __enter__(self) -> BenchWorld:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
