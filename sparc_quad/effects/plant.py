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
import math
from collections import deque
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from sparc_quad.effects.base import Effect, FrictionLaw, PlantEffectsError
from sparc_quad.effects.registry import EFFECTS, kind

SCHEMA = "sparc-quad/plant-effects/1"
TOP_KEYS = ("schema", "joints", "friction_smoothing_rad_s", "effects")
MAX_PARAM = 1e6  # |a parameter| beyond this (N*m, kg*m^2, s, rad, ...) is garbage, not a plant
MAX_DELAY_S = 10.0
MAX_SMOOTHING_RAD_S = 100.0


def _bad_number(v) -> str | None:
    if isinstance(v, bool) or not isinstance(v, int | float):
        return f"must be a number, got {json.dumps(v)[:40]}"
    if not math.isfinite(v):
        return f"must be finite, got {v}"
    if abs(v) > MAX_PARAM:
        return f"{v:g} beyond {MAX_PARAM:g} (not a physical value)"
    return None


def check_plant_dict(d) -> None:
    """Type, finiteness and range of every key of a plant file, before any is used; PlantEffectsError
    naming the key. Parameters are numbers (lists of numbers for list-valued ones, e.g. a direction);
    extra text entries beside them (a link-inertia `combination`) are kept as they are."""
    if not isinstance(d, dict):
        raise PlantEffectsError(f"a plant file is a JSON object, got {type(d).__name__}")
    if d.get("schema") != SCHEMA:
        raise PlantEffectsError(f"plant file schema {d.get('schema')!r}, expected {SCHEMA!r}")
    unknown = sorted(set(d) - set(TOP_KEYS))
    if unknown:
        raise PlantEffectsError(f"unknown key(s) {unknown}; a plant file has {list(TOP_KEYS)}")
    joints = d.get("joints")
    if not isinstance(joints, list) or not joints or not all(isinstance(j, str) and j for j in joints):
        raise PlantEffectsError(f"joints must be a non-empty list of names, got {json.dumps(joints)[:60]}")
    eps = d.get("friction_smoothing_rad_s", 0.01)
    why = _bad_number(eps)
    if why is None and not 0 < eps <= MAX_SMOOTHING_RAD_S:
        why = f"must be in (0, {MAX_SMOOTHING_RAD_S:g}] rad/s, got {eps}"
    if why:
        raise PlantEffectsError(f"friction_smoothing_rad_s {why}")
    effects = d.get("effects", [])
    if not isinstance(effects, list):
        raise PlantEffectsError(f"effects must be a list, got {type(effects).__name__}")
    for i, e in enumerate(effects):
        where = f"effects[{i}]"
        if not isinstance(e, dict):
            raise PlantEffectsError(f"{where} must be an object, got {json.dumps(e)[:40]}")
        name = e.get("name")
        if not isinstance(name, str) or name not in EFFECTS:
            raise PlantEffectsError(f"{where}.name {json.dumps(name)[:40]} is not an effect "
                                    f"({', '.join(EFFECTS)})")
        if e.get("joint") not in joints:
            raise PlantEffectsError(f"{where}.joint {json.dumps(e.get('joint'))[:40]} not in {joints}")
        params = e.get("params", {})
        if not isinstance(params, dict):
            raise PlantEffectsError(f"{where}.params must be an object, got {type(params).__name__}")
        for key in kind(name).param_keys():
            if key not in params:
                continue
            v = params[key]
            for x in (v if isinstance(v, list) else [v]):
                why = _bad_number(x)
                if why:
                    raise PlantEffectsError(f"{where}.params.{key} ({name}) {why}")
        for key, v in params.items():
            if key not in kind(name).param_keys() and not isinstance(v, str):
                raise PlantEffectsError(f"{where}.params: unknown parameter {key!r} of {name} "
                                        f"(known: {', '.join(kind(name).param_keys())})")


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
        """From a parsed plant file; every key checked first (`check_plant_dict`): a PlantEffectsError
        names the key."""
        check_plant_dict(d)
        pe = PlantEffects(d["joints"], [Effect.from_dict(e) for e in d.get("effects", [])],
                          d.get("friction_smoothing_rad_s", 0.01))
        for j, name in enumerate(pe.joints):
            if pe.arm[j] < 0:
                raise PlantEffectsError(f"rotor inertia of {name} sums to {pe.arm[j]:g} kg*m^2 (< 0)")
            if not 0 <= pe.delay[j] <= MAX_DELAY_S:
                raise PlantEffectsError(f"time delay of {name} sums to {pe.delay[j]:g} s "
                                        f"(not in 0..{MAX_DELAY_S:g})")
        return pe

    def save(self, path: str | Path) -> None:
        """JSON without NaN or infinity tokens (json refuses them here rather than write invalid JSON)."""
        Path(path).write_text(json.dumps(self.to_dict(), indent=2, allow_nan=False) + "\n")

    @staticmethod
    def load(path: str | Path) -> PlantEffects:
        path = Path(path)
        try:
            if not path.is_file():
                raise PlantEffectsError(f"{path}: not a regular file")
            text = path.read_bytes().decode("utf-8-sig")
            return PlantEffects.from_dict(json.loads(text))
        except UnicodeDecodeError as exc:
            raise PlantEffectsError(f"{path}: not UTF-8 text (byte {exc.start})") from None
        except (OSError, json.JSONDecodeError) as exc:
            raise PlantEffectsError(f"{path}: {exc}") from exc
        except PlantEffectsError as exc:
            msg = str(exc)
            raise PlantEffectsError(msg if msg.startswith(str(path)) else f"{path}: {msg}") from None

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
