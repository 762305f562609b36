"""`gap synth`: trials from a simulated fixed-base chain (default: the bench spine, q1 = 0) with effects
hidden from the nominal model.

Plant: pinocchio forward dynamics (mass matrix with the plant's armature and payloads, friction linearly
implicit at the step's midpoint velocity) at the log rate, semi-implicit Euler, torque zero-order hold.
pybullet cannot express rotor inertia (no armature), so
the synthetic plant is pinocchio's; it loads the same plant-effects file the pybullet worlds load.
The nominal plant carries the spine's nominal Stribeck friction (`spine_module.params.NOMINAL_FRICTION`),
the controller compensates it; the true plant = nominal + hidden effects, plus torque noise
(process, `torque_noise_nm` 1 sigma per sample) and CyberGear encoder quantisation on q and dq.
Controller: computed torque from the nominal model along a periodic Fourier excitation, plus joint PD on
the measured state, clamped to the URDF effort limit; the log records the commanded torque.
"""

from __future__ import annotations

import json
import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pinocchio as pin

from sparc_quad.effects import Effect, kind
from sparc_quad.effects.plant import PlantEffects
from sparc_quad.gap.robot import Robot
from sparc_quad.gap.trial import Trial, save_trial
from sparc_quad.robots import spine_urdf_path
from spine_module import params as P
from spine_module.messages.motor import MotorCommand

SPINE_URDF = spine_urdf_path()

_LISTS = ("xyz_m", "direction")  # list-valued parameters, written u1;u2;...


def parse_effect_spec(spec: str, robot: Robot, default_joint: str | None = None) -> Effect:
    """`NAME[:joint=q3,param=value,...]` -> Effect with defaults filled in (SI units)."""
    name, _, rest = spec.partition(":")
    k = kind(name.strip())
    kv: dict[str, str] = {}
    for item in filter(None, (s.strip() for s in rest.split(","))):
        key, eq, v = item.partition("=")
        if not eq:
            raise ValueError(f"{spec!r}: expected key=value, got {item!r}")
        kv[key.strip()] = v.strip()
    joint = kv.pop("joint", default_joint or robot.actuated[len(robot.actuated) // 2])
    if joint not in robot.actuated:
        raise ValueError(f"{spec!r}: joint {joint!r} is not an actuated joint ({robot.actuated})")
    allowed = {*k.param_keys(), *k.SYNTH_ONLY}
    unknown = set(kv) - allowed
    if unknown:
        raise ValueError(f"{spec!r}: unknown parameter(s) {sorted(unknown)}; {k.NAME} takes "
                         f"{sorted(allowed)}")
    given: dict = {}
    for key, v in kv.items():
        try:
            given[key] = [float(x) for x in v.split(";")] if key in _LISTS else float(v)
        except ValueError:
            raise ValueError(f"{spec!r}: {key}={v!r} is not a number") from None
    try:
        params, link = k.synth_params(given, robot, joint)
    except ValueError as exc:
        raise ValueError(f"{spec!r}: {exc}") from None
    return Effect(k.NAME, joint, params, link)


def nominal_spine_plant(joints: Sequence[str]) -> PlantEffects:
    f = P.NOMINAL_FRICTION
    effects = []
    for j in joints:
        effects += [Effect("rotor_inertia", j, {"inertia_kg_m2": P.REFLECTED_ROTOR_INERTIA_KG_M2}),
                    Effect("coulomb_friction", j, {"tau_c_nm": f.tau_c_nm}),
                    Effect("stribeck_friction", j, {"tau_s_nm": f.tau_s_nm - f.tau_c_nm,
                                                     "dq_s_rad_s": f.dq_s_rad_s}),
                    Effect("viscous_friction", j, {"b_nm_s_rad": f.b_nm_s_rad})]
    return PlantEffects(joints, effects, 1.0 / f.beta_s_rad)


@dataclass
class Excitation:
    q0: np.ndarray
    a: np.ndarray  # (H, n) sine coefficients
    b: np.ndarray  # (H, n) cosine coefficients
    period_s: float

    def __call__(self, t: np.ndarray):
        h = np.arange(1, self.a.shape[0] + 1)[:, None]
        w = 2 * np.pi * h / self.period_s  # (H, 1)
        wt = w[None] * t[:, None, None]  # (N, H, 1)
        s, c = np.sin(wt), np.cos(wt)
        q = self.q0 + (s * self.a + (c - 1) * self.b).sum(1)
        dq = (w * (c * self.a - s * self.b)).sum(1)
        ddq = (-(w**2) * (s * self.a + c * self.b)).sum(1)
        return q, dq, ddq


def random_excitation(robot: Robot, q0: np.ndarray, rng: np.random.Generator, amp_rad: float = 0.3,
                      period_s: float = 4.0, harmonics: int = 5) -> Excitation:
    n = robot.nv
    a = rng.normal(size=(harmonics, n)) / np.arange(1, harmonics + 1)[:, None] ** 0.5
    b = rng.normal(size=(harmonics, n)) / np.arange(1, harmonics + 1)[:, None] ** 0.5
    ex = Excitation(q0, a, b, period_s)
    t = np.linspace(0, period_s, 2000)
    q, _, _ = ex(t)
    scale = amp_rad / np.max(np.abs(q - q0), axis=0)
    ex.a, ex.b = a * scale, b * scale
    return ex


def informative_excitation(robot: Robot, model, q0: np.ndarray, rng: np.random.Generator,
                           amp_rad: float, period_s: float, tries: int = 12) -> Excitation:
    """Of `tries` random excitations, the one whose nominal torque changes sign most on its worst joint
    (a torque that never changes sign cannot separate an offset from a deadband, nor a gain from an
    offset well)."""
    t = np.linspace(0.0, period_s, 300, endpoint=False)
    best, best_score = None, -1.0
    for _ in range(tries):
        ex = random_excitation(robot, q0, rng, amp_rad, period_s)
        tau = Robot.rnea(model, *ex(t))[:, robot.act_idx]
        score = float(np.min(np.minimum((tau > 0).mean(0), (tau < 0).mean(0))))
        if score > best_score:
            best, best_score = ex, score
    return best


def simulate(robot: Robot, true_plant: PlantEffects, nominal_plant: PlantEffects, ex: Excitation,
             duration_s: float, rate_hz: float, rng: np.random.Generator, torque_noise_nm: float = 0.02,
             bandwidth_hz: float = 8.0, unmodelled: Callable | None = None,
             quantise: bool = True) -> Trial:
    """Closed-loop run; returns a Trial (measured q, dq; commanded tau).

    Joint PD gains from the nominal mass matrix's diagonal at the excitation's centre (at least 1 % of its
    largest entry): kp = M_jj w^2, kd = 1.4 M_jj w, w = 2 pi bandwidth_hz.
    """
    if len(robot.actuated) != robot.nv:
        raise ValueError("synth needs every non-fixed joint actuated")
    dt = 1.0 / rate_hz
    n_steps = round(duration_s * rate_hz)
    t = np.arange(n_steps) * dt
    q_d, dq_d, ddq_d = ex(t)
    nom_model = robot.plant_model(nominal_plant)
    ff = Robot.rnea(nom_model, q_d, dq_d, ddq_d) - nominal_plant.friction_torque(dq_d)
    w = 2 * np.pi * bandwidth_hz
    m_diag = np.diag(pin.crba(nom_model, nom_model.createData(), ex.q0))
    m_diag = np.maximum(m_diag, 1e-2 * m_diag.max())  # a massless link still gets a (soft) servo
    kp, kd = m_diag * w**2, 1.4 * m_diag * w
    true_model = robot.plant_model(true_plant)
    data = true_model.createData()
    limit = np.array([robot.model.effortLimit[i] for i in robot.act_idx])
    limit = np.where(limit > 0, limit, np.inf)
    lsb_q, lsb_dq = (P.SENSORS.position_lsb_rad, P.SENSORS.velocity_lsb_rad_s) if quantise else (0, 0)
    def quant(x, lsb):
        return np.round(x / lsb) * lsb if lsb else x

    q, dq = q_d[0].copy(), dq_d[0].copy()
    Q, DQ, TAU = (np.empty((n_steps, robot.nv)) for _ in range(3))
    noise = rng.normal(scale=torque_noise_nm, size=(n_steps, robot.nv))
    true_plant.reset(dt)
    for k in range(n_steps):
        qm = quant(true_plant.measured_q(q), lsb_q)
        dqm = quant(dq, lsb_dq)
        cmd = MotorCommand(tau_ff=ff[k], q_des=q_d[k], dq_des=dq_d[k], kp=kp, kd=kd)
        tau = np.clip(cmd.torque(qm, dqm), -limit, limit)
        Q[k], DQ[k], TAU[k] = qm, dqm, tau
        tj = np.zeros(robot.nv)
        tj[robot.act_idx] = true_plant.applied_torque(tau) + noise[k]
        if unmodelled is not None:
            tj = tj + unmodelled(q, dq)
        q, dq = robot.forward_step(true_model, data, q, dq, tj, true_plant, dt)
        if not np.all(np.isfinite(q)):
            raise RuntimeError(f"synthetic plant diverged at t={t[k]:.3f} s")
    return Trial(Path("synth.csv"), {}, t, Q, DQ, TAU, None, None, robot)


def cogging(joint_index: int, amp_nm: float = 0.12, cycles_per_rad: float = 6.0 / np.pi) -> Callable:
    """An effect outside the library: position-periodic cogging torque on one joint."""
    def fn(q, dq):
        out = np.zeros_like(q)
        out[joint_index] = amp_nm * np.sin(2 * np.pi * cycles_per_rad * q[joint_index])
        return out
    return fn


def synth(out: str | Path, effects: Sequence[str | Effect] = (), *, seed: int = 0, n_trials: int = 3,
          periods: int = 3, period_s: float = 4.0, rate_hz: float = 1000.0, amp_rad: float = 0.3,
          urdf: str | Path = SPINE_URDF, actuated: Sequence[str] = P.ACTUATED_JOINTS,
          fixed: dict | None = None, gravity: Sequence[float] = (0, 0, -P.GRAVITY_M_S2),
          q0: Sequence[float] | None = None, nominal: PlantEffects | None = None,
          unmodelled: str | None = None, torque_noise_nm: float = 0.02,
          optimise_excitation: bool = True) -> dict:
    """Write `n_trials` trials (each `periods` repeats of a random excitation) into `out`.

    Returns {"trials": [csv paths], "nominal_plant": path, "true_plant": path, "hidden": [effects]}.
    The hidden effects are written to `true_plant.json` and `truth.json` (never read by `gap`).
    """
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    fixed = {"q1": 0.0} if fixed is None and Path(urdf) == SPINE_URDF else dict(fixed or {})
    robot = Robot(urdf, actuated, fixed, gravity)
    if q0 is None:
        q0 = (P.Q_EQUILIBRIUM[1:] if Path(urdf) == SPINE_URDF else 0.5 * (robot.lower + robot.upper))
    q0 = np.asarray(q0, dtype=float)
    nominal = nominal if nominal is not None else nominal_spine_plant(robot.actuated)
    rng = np.random.default_rng(seed)
    if optimise_excitation:
        model = robot.plant_model(nominal)
        exc = [informative_excitation(robot, model, q0, rng, amp_rad, period_s) for _ in range(n_trials)]
    else:
        exc = [random_excitation(robot, q0, rng, amp_rad, period_s) for _ in range(n_trials)]
    hidden = [e if isinstance(e, Effect) else parse_effect_spec(e, robot) for e in effects]
    duration = periods * period_s
    def nominal_peak_nm(j: int) -> float:  # peak |tau_cmd| of joint j over the trials, nominal plant
        return min(np.max(np.abs(simulate(robot, nominal, nominal, ex, period_s, rate_hz,
                                          np.random.default_rng(0), 0.0).tau_cmd[:, j])) for ex in exc)

    for e in hidden:
        kind(e.name).resolve_synth(e.params, robot.actuated.index(e.joint), nominal_peak_nm)
    true_plant = nominal.with_effects(hidden)
    unmod_fn = None
    if unmodelled == "cogging":
        unmod_fn = cogging(len(robot.actuated) // 2)
    elif unmodelled is not None:
        raise ValueError(f"unknown unmodelled effect {unmodelled!r} (known: cogging)")
    nominal.save(out / "nominal_plant.json")
    true_plant.save(out / "true_plant.json")
    paths = []
    for i, ex in enumerate(exc):
        tr = simulate(robot, true_plant, nominal, ex, duration, rate_hz, rng, torque_noise_nm,
                      unmodelled=unmod_fn)
        csv_path = out / f"trial_{i:02d}.csv"
        meta = {"urdf": os.path.relpath(robot.urdf, out), "actuated_joints": list(robot.actuated),
                "fixed_joints": fixed, "gravity": list(gravity), "rate_hz": rate_hz,
                "period_s": period_s, "plant": "nominal_plant.json",
                "description": f"gap synth seed {seed} trial {i}: periodic excitation, "
                               f"{len(hidden)} hidden effect(s)"}
        save_trial(tr, csv_path, meta)
        paths.append(csv_path)
    truth = {"hidden": [e.to_dict() for e in hidden], "unmodelled": unmodelled, "seed": seed}
    (out / "truth.json").write_text(json.dumps(truth, indent=2) + "\n")
    return {"trials": paths, "nominal_plant": out / "nominal_plant.json",
            "true_plant": out / "true_plant.json", "hidden": hidden}
