"""Plant effects: what a real actuator and its load add to a rigid-body URDF model.

One file format, read by every simulation that takes `--plant FILE` (the bench spine, the quadruped, the
gap workflow's replay and `gap synth`), written by the gap workflow (`DIR/plant.json`).

Schema (JSON, SI units)::

    {"schema": "sparc-quad/plant-effects/1",
     "joints": ["q2", "q3", "q4"],              # actuated joints, the order of every torque array
     "friction_smoothing_rad_s": 0.01,          # sign(dq) is tanh(dq / this), as in eq. (4)
     "effects": [{"name": "coulomb_friction", "joint": "q3", "params": {"tau_c_nm": 0.1}}, ...]}

Effect names and parameters (the gap workflow's library; several entries of one kind add up):

    coulomb_friction   joint  tau_c_nm                 friction  -tau_c tanh(dq/eps)
    viscous_friction   joint  b_nm_s_rad               friction  -b dq
    stribeck_friction  joint  tau_s_nm, dq_s_rad_s     friction  -tau_s exp(-(|dq|/dq_s)^2) tanh(dq/eps)
                                                       (the breakaway excess above Coulomb)
    rotor_inertia      joint  inertia_kg_m2            reflected rotor inertia added to M (armature)
    torque_gain        joint  gain                     applied = gain * commanded
    torque_offset      joint  offset_nm                applied = commanded + offset
    time_delay         joint  delay_s                  applied(t) = commanded(t - delay)
    payload_mass       joint  mass_kg, xyz_m           point mass on the joint's child link at xyz_m
                                                       (link frame); the entry also names its "link"
    encoder_offset     joint  offset_rad               measured q = true q + offset
    torque_saturation  joint  limit_nm                 applied clipped to +-limit
    torque_deadband    joint  width_nm                 applied = sign(c) max(|c| - width, 0)
    asymmetric_coulomb joint  delta_nm                 friction  -delta |tanh(dq/eps)|: the Coulomb level
                                                       is tau_c + delta moving +, tau_c - delta moving -
    coupled_rotor_inertia     direction, inertia_kg_m2 one motor turning with s = u . q (u: `direction`,
    coupled_coulomb_friction  direction, tau_c_nm      one entry per joint, e.g. a wrist motor on q5 + q6):
    coupled_viscous_friction  direction, b_nm_s_rad    M += I u u^T; friction -u (tau_c tanh(s'/eps) + b s')
                                                       (`joint` names the joint the motor is listed with)
    link_inertia       joint  param_index, delta       error `delta` in standard dynamic parameter
                                                       `param_index` (pinocchio order m, mx, my, mz, Ixx, Ixy,
                                                       Iyy, Ixz, Iyz, Izz; SI) of the joint's body; the gap
                                                       report adds the identifiable `combination`

Actuator chain per control step, in this order: delay -> deadband -> gain -> offset -> saturation.

How a simulation uses it (per control step of length dt, torques ordered as `joints`)::

    pe = PlantEffects.load(path); pe.reset(dt)
    model = pe.apply_to_pinocchio(model, joint_names)     # armature + payloads (pinocchio plants)
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
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

SCHEMA = "sparc-quad/plant-effects/1"

EFFECT_PARAMS: dict[str, tuple[str, ...]] = {
    "coulomb_friction": ("tau_c_nm",),
    "viscous_friction": ("b_nm_s_rad",),
    "stribeck_friction": ("tau_s_nm", "dq_s_rad_s"),
    "rotor_inertia": ("inertia_kg_m2",),
    "torque_gain": ("gain",),
    "torque_offset": ("offset_nm",),
    "time_delay": ("delay_s",),
    "payload_mass": ("mass_kg", "xyz_m"),
    "encoder_offset": ("offset_rad",),
    "torque_saturation": ("limit_nm",),
    "torque_deadband": ("width_nm",),
    "asymmetric_coulomb": ("delta_nm",),
    "coupled_rotor_inertia": ("direction", "inertia_kg_m2"),
    "coupled_coulomb_friction": ("direction", "tau_c_nm"),
    "coupled_viscous_friction": ("direction", "b_nm_s_rad"),
    "link_inertia": ("param_index", "delta"),
}
COUPLED = ("coupled_rotor_inertia", "coupled_coulomb_friction", "coupled_viscous_friction")
EFFECT_NAMES: tuple[str, ...] = tuple(EFFECT_PARAMS)


class PlantEffectsError(ValueError):
    """A plant file or effect entry that cannot be used."""


@dataclass
class Effect:
    name: str
    joint: str | None
    params: dict
    link: str | None = None  # payload_mass only
    extra: dict = field(default_factory=dict)  # free-form annotations (e.g. "ambiguous_with")

    def to_dict(self) -> dict:
        d = {"name": self.name, "joint": self.joint, "params": dict(self.params)}
        if self.link is not None:
            d["link"] = self.link
        d.update(self.extra)
        return d

    @staticmethod
    def from_dict(d: dict) -> Effect:
        name = d.get("name")
        if name not in EFFECT_PARAMS:
            raise PlantEffectsError(f"unknown effect {name!r}; known: {', '.join(EFFECT_NAMES)}")
        params = dict(d.get("params", {}))
        for key in EFFECT_PARAMS[name]:
            if key == "xyz_m":
                params.setdefault("xyz_m", [0.0, 0.0, 0.0])
            elif key not in params:
                raise PlantEffectsError(f"effect {name}: missing parameter {key!r}")
        extra = {k: v for k, v in d.items() if k not in ("name", "joint", "params", "link")}
        return Effect(name, d.get("joint"), params, d.get("link"), extra)


class PlantEffects:
    """The effects of one plant, with the hooks a simulation calls (see the module docstring)."""

    def __init__(self, joints: Sequence[str], effects: Sequence[Effect] = (),
                 friction_smoothing_rad_s: float = 0.01):
        self.joints = list(joints)
        self.effects = [copy.deepcopy(e) for e in effects]
        self.eps = float(friction_smoothing_rad_s)
        for e in self.effects:
            if e.joint is not None and e.joint not in self.joints:
                raise PlantEffectsError(f"effect {e.name}: joint {e.joint!r} not in {self.joints}")
            if e.joint is None:
                raise PlantEffectsError(f"effect {e.name}: needs a joint")
        self._rebuild()
        self._dt: float | None = None
        self._buffers: list[deque] = []

    # ---- construction and files -----------------------------------------------------------------
    def _rebuild(self) -> None:
        n = len(self.joints)
        z = np.zeros
        self.coulomb, self.viscous, self.arm = z(n), z(n), z(n)
        self.stribeck: list[tuple[int, float, float]] = []  # (joint index, tau_s, dq_s); several add up
        self.gain, self.offset, self.delay = np.ones(n), z(n), z(n)
        self.enc_offset, self.limit, self.deadband = z(n), np.full(n, np.inf), z(n)
        self.asym = z(n)
        self.coupled_M = np.zeros((n, n))  # sum of I u u^T
        self.coupled_fr: list[tuple[np.ndarray, float, float]] = []  # (u, tau_c, b)
        for e in self.effects:
            j = self.joints.index(e.joint)
            p = e.params
            match e.name:
                case "coulomb_friction":
                    self.coulomb[j] += p["tau_c_nm"]
                case "viscous_friction":
                    self.viscous[j] += p["b_nm_s_rad"]
                case "stribeck_friction":
                    self.stribeck.append((j, float(p["tau_s_nm"]), float(p["dq_s_rad_s"])))
                case "rotor_inertia":
                    self.arm[j] += p["inertia_kg_m2"]
                case "torque_gain":
                    self.gain[j] *= p["gain"]
                case "torque_offset":
                    self.offset[j] += p["offset_nm"]
                case "time_delay":
                    self.delay[j] += p["delay_s"]
                case "encoder_offset":
                    self.enc_offset[j] += p["offset_rad"]
                case "torque_saturation":
                    self.limit[j] = min(self.limit[j], p["limit_nm"])
                case "torque_deadband":
                    self.deadband[j] += p["width_nm"]
                case "payload_mass":
                    pass
                case "asymmetric_coulomb":
                    self.asym[j] += p["delta_nm"]
                case "coupled_rotor_inertia" | "coupled_coulomb_friction" | "coupled_viscous_friction":
                    u = np.asarray(p["direction"], dtype=float)
                    if u.shape != (n,) or not np.all(np.isfinite(u)):
                        raise PlantEffectsError(f"effect {e.name}: direction needs {n} finite numbers")
                    if e.name == "coupled_rotor_inertia":
                        self.coupled_M += float(p["inertia_kg_m2"]) * np.outer(u, u)
                    elif e.name == "coupled_coulomb_friction":
                        self.coupled_fr.append((u, float(p["tau_c_nm"]), 0.0))
                    else:
                        self.coupled_fr.append((u, 0.0, float(p["b_nm_s_rad"])))
        # Stribeck terms as arrays: joint index, amplitude, velocity, and a (n, terms) indicator
        self._st_j = np.array([s[0] for s in self.stribeck], dtype=int)
        self._st_tau = np.array([s[1] for s in self.stribeck], dtype=float)
        self._st_dqs = np.array([s[2] for s in self.stribeck], dtype=float)
        self._st_sum = np.zeros((n, len(self.stribeck)))
        self._st_sum[self._st_j, np.arange(len(self.stribeck))] = 1.0

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
        tau = np.sign(tau) * np.maximum(np.abs(tau) - self.deadband, 0.0)
        tau = self.gain * tau + self.offset
        return np.clip(tau, -self.limit, self.limit)

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
        """(friction torque, -its derivative in dq)."""
        dq = np.asarray(dq, dtype=float)
        th = np.tanh(dq / self.eps)
        mag, dmag = self.coulomb + np.zeros_like(dq), np.zeros_like(dq)
        if self.stribeck:
            x = dq[..., self._st_j] / self._st_dqs
            e = self._st_tau * np.exp(-(x**2))
            mag = mag + e @ self._st_sum.T
            dmag = (e * (-2.0 * x / self._st_dqs)) @ self._st_sum.T
        torque = -(mag * th + self.viscous * dq + self.asym * np.abs(th))
        slope = dmag * th + (mag + self.asym * np.sign(th)) * (1.0 - th**2) / self.eps + self.viscous
        for u, tc, b in self.coupled_fr:  # slope: the diagonal of the coupled Jacobian
            sv = dq @ u
            ts = np.tanh(sv / self.eps)
            torque = torque - (tc * ts + b * sv)[..., None] * u
            slope = slope + (tc * (1.0 - ts**2) / self.eps + b)[..., None] * u**2
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

    def payloads(self) -> list[Effect]:
        return [e for e in self.effects if e.name == "payload_mass"]

    def apply_to_pinocchio(self, model, joint_names: Sequence[str] | None = None):
        """A copy of a pinocchio model with this plant's armature and payloads.

        `joint_names`: the model's joint names (default: read from the model). Payloads go on the
        child link of their joint (the joint's body in pinocchio).
        """
        import pinocchio as pin

        m = model.copy()
        for j, name in enumerate(self.joints):
            if not m.existJointName(name):
                raise PlantEffectsError(f"joint {name!r} not in the pinocchio model")
            jid = m.getJointId(name)
            m.armature[m.joints[jid].idx_v] += self.arm[j]
        deltas: dict[int, np.ndarray] = {}
        for e in self.effects:
            if e.name == "link_inertia":
                jid = m.getJointId(e.joint)
                deltas.setdefault(jid, np.zeros(10))[int(e.params["param_index"])] += float(e.params["delta"])
        for jid, dpi in deltas.items():
            pi = m.inertias[jid].toDynamicParameters() + dpi
            if not pi[0] > 0:
                raise PlantEffectsError(f"link_inertia on {m.names[jid]!r}: mass {pi[0]:.4g} kg is not "
                                        "positive")
            m.inertias[jid] = pin.Inertia.FromDynamicParameters(pi)
        for e in self.payloads():
            jid = m.getJointId(e.joint)
            xyz = np.asarray(e.params.get("xyz_m", [0.0, 0.0, 0.0]), dtype=float)
            point = pin.Inertia(float(e.params["mass_kg"]), xyz, np.zeros((3, 3)))
            m.inertias[jid] = m.inertias[jid] + point
        return m
