"""The plant-effects file and the hooks a simulation calls: the effect kinds' contributions added up.

Schema (JSON, SI units)::

    {"schema": "sparc-quad/plant-effects/1",
     "joints": ["q2", "q3", "q4"],              # actuated joints, the order of every torque array
     "friction_smoothing_rad_s": 0.01,          # sign(dq) is tanh(dq / this), as in eq. (4)
     "effects": [{"name": "coulomb_friction", "joint": "q3", "params": {"tau_c_nm": 0.1}}, ...]}

The kinds and their parameters: `sparc_quad.effects` (docs/gap.md has the table); several entries of one
kind add up. Actuator chain per control step: delay, then the kinds' stages in STAGE order (deadband ->
gain -> offset -> saturation).

How a simulation uses it (per control step of length dt, torques ordered as `joints`)::

    pe = PlantEffects.load(path); pe.reset(dt)
    model = pe.apply_to_pinocchio(model, joint_names)     # armature + inertial changes (pinocchio plants)
    q_meas = pe.measured_q(q_true)                         # what the controller and the log see
    tau_joint = pe.applied_torque(tau_cmd) + pe.friction_torque(dq)   # torque the joint receives

pybullet has no armature: a pybullet world reads `pe.armature()` and either refuses a non-zero value or
emulates it (see the module docstring of the bench world); payloads go into the URDF or changeDynamics.
"""

from __future__ import annotations

import copy
import json
from collections import deque
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from sparc_quad.effects.base import Effect, FrictionLaw, PlantEffectsError
from sparc_quad.effects.registry import EFFECTS, kind

SCHEMA = "sparc-quad/plant-effects/1"


class PlantEffects:
    """The effects of one plant, with the hooks a simulation calls (see the module docstring)."""

    def __init__(self, joints: Sequence[str], effects: Sequence[Effect] = (),
                 friction_smoothing_rad_s: float = 0.01):
        self.joints = list(joints)
        self.effects = [copy.deepcopy(e) for e in effects]
        self.eps = float(friction_smoothing_rad_s)
        for e in self.effects:
            kind(e.name)
            if e.joint is None:
                raise PlantEffectsError(f"effect {e.name}: needs a joint")
            if e.joint not in self.joints:
                raise PlantEffectsError(f"effect {e.name}: joint {e.joint!r} not in {self.joints}")
        self._rebuild()
        self._dt: float | None = None
        self._buffers: list[deque] = []

    # ---- construction and files -----------------------------------------------------------------
    def _rebuild(self) -> None:
        """Each kind present builds its state from its entries (registry order); the per-joint channels
        (encoder offset, delay, armature, coupled inertia) are the sums of the kinds' contributions."""
        n = len(self.joints)
        by_kind: dict[str, list] = {}
        for e in self.effects:
            by_kind.setdefault(e.name, []).append((self.joints.index(e.joint), e.params, e))
        self.kinds = [(EFFECTS[name], EFFECTS[name].build(by_kind[name], n)) for name in EFFECTS
                      if name in by_kind]
        self.enc_offset, self.delay, self.arm = np.zeros(n), np.zeros(n), np.zeros(n)
        self.coupled_M = np.zeros((n, n))  # sum of I u u^T
        for k, state in self.kinds:
            for total, hook in ((self.enc_offset, k.encoder_offset_rad), (self.delay, k.delay_s),
                                (self.arm, k.armature_kg_m2), (self.coupled_M, k.coupled_mass)):
                part = hook(state)
                if part is not None:
                    total += part
        # friction outside the law: once per entry, in the file's order, with the state of that entry alone
        self._own_friction = []
        for e in self.effects:
            k = EFFECTS[e.name]
            if k.has_own_friction():
                self._own_friction.append((k, k.build([(self.joints.index(e.joint), e.params, e)], n)))
        self._stages = sorted(((k, s) for k, s in self.kinds if k.STAGE is not None),
                              key=lambda ks: ks[0].STAGE)

    def with_effects(self, extra: Sequence[Effect]) -> PlantEffects:
        return PlantEffects(self.joints, [*self.effects, *extra], self.eps)

    def to_dict(self) -> dict:
        return {"schema": SCHEMA, "joints": self.joints, "friction_smoothing_rad_s": self.eps,
                "effects": [e.to_dict() for e in self.effects]}

    @staticmethod
    def from_dict(d: dict) -> PlantEffects:
        if d.get("schema") != SCHEMA:
            raise PlantEffectsError(f"plant file schema {d.get('schema')!r}, expected {SCHEMA!r}")
        return PlantEffects(d["joints"], [Effect.from_dict(e) for e in d.get("effects", [])],
                            d.get("friction_smoothing_rad_s", 0.01))

    def save(self, path: str | Path) -> None:
        Path(path).write_text(json.dumps(self.to_dict(), indent=2) + "\n")

    @staticmethod
    def load(path: str | Path) -> PlantEffects:
        try:
            return PlantEffects.from_dict(json.loads(Path(path).read_text()))
        except (OSError, json.JSONDecodeError, KeyError) as exc:
            raise PlantEffectsError(f"{path}: {exc}") from exc

    # ---- hooks --------------------------------------------------------------------------------------
    def reset(self, dt: float) -> None:
        """Start a run with control period dt (s): clears the delay lines."""
        self._dt = float(dt)
        steps = np.round(self.delay / dt).astype(int)
        self._buffers = [deque([0.0] * int(s), maxlen=int(s)) if s > 0 else deque() for s in steps]

    def applied_torque(self, tau_cmd: np.ndarray) -> np.ndarray:
        """Commanded -> applied joint torque for one control step (stateful when a delay is set)."""
        tau = np.array(tau_cmd, dtype=float)
        if np.any(self.delay > 0):
            if self._dt is None:
                raise PlantEffectsError("call reset(dt) before applied_torque with a time delay")
            for j, buf in enumerate(self._buffers):
                if buf.maxlen:
                    out = buf[0]
                    buf.append(tau[j])
                    tau[j] = out
        return self._static_actuator(tau)

    def _static_actuator(self, tau: np.ndarray) -> np.ndarray:
        for k, state in self._stages:
            tau = k.actuate(state, tau)
        return tau

    def applied_torque_series(self, tau_cmd: np.ndarray, dt: float) -> np.ndarray:
        """Whole-log version of `applied_torque`: tau_cmd (N, n) sampled every dt, zeros before t0."""
        tau = np.array(tau_cmd, dtype=float)
        for j in range(tau.shape[1]):
            s = round(self.delay[j] / dt)
            if s > 0:
                tau[s:, j] = tau_cmd[:-s, j]
                tau[:s, j] = 0.0
        return self._static_actuator(tau)

    def friction_torque(self, dq: np.ndarray) -> np.ndarray:
        """Torque the friction terms put on the joints (opposes motion); dq (n,) or (N, n)."""
        return self._friction(dq)[0]

    def _friction(self, dq: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(friction torque, -its derivative in dq (diagonal)), the kinds' contributions added up."""
        dq = np.asarray(dq, dtype=float)
        law = FrictionLaw(dq, np.tanh(dq / self.eps), self.eps)
        for k, state in self.kinds:
            k.friction_law(state, law)
        torque, slope = law.torque_and_slope()
        for k, state in self._own_friction:
            torque, slope = k.friction(state, law, torque, slope)
        return torque, slope

    def coupled_inertia_torque(self, ddq: np.ndarray) -> np.ndarray:
        """Torque the coupled rotor inertias need for joint accelerations ddq ((n,) or (N, n))."""
        return np.asarray(ddq, dtype=float) @ self.coupled_M.T

    def friction_slope(self, dq: np.ndarray) -> np.ndarray:
        """-d friction_torque / d dq (>= 0 where dissipative): for linearly-implicit integration."""
        return self._friction(dq)[1]

    def friction_and_slope(self, dq: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return self._friction(dq)

    def measured_q(self, q_true: np.ndarray) -> np.ndarray:
        return np.asarray(q_true, dtype=float) + self.enc_offset

    def true_q(self, q_meas: np.ndarray) -> np.ndarray:
        return np.asarray(q_meas, dtype=float) - self.enc_offset

    def armature(self) -> np.ndarray:
        return self.arm.copy()

    def model_effects(self) -> list[Effect]:
        """The entries that change the rigid-body model (what a pybullet world cannot take from here)."""
        return [e for e in self.effects if kind(e.name).changes_model()]

    def apply_to_pinocchio(self, model, joint_names: Sequence[str] | None = None):
        """A copy of a pinocchio model with this plant's armature and the kinds' inertial changes.

        `joint_names`: the model's joint names (default: read from the model). Payloads go on the
        child link of their joint (the joint's body in pinocchio).
        """
        m = model.copy()
        for j, name in enumerate(self.joints):
            if not m.existJointName(name):
                raise PlantEffectsError(f"joint {name!r} not in the pinocchio model")
            jid = m.getJointId(name)
            m.armature[m.joints[jid].idx_v] += self.arm[j]
        for k, state in self.kinds:
            m = k.apply_to_model(state, m, self.joints)
        return m
