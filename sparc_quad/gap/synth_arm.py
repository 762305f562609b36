"""`gap synth-arm`: trials from a simulated 6-DoF arm with what a real industrial arm hides from its URDF.

Robot: the UR5 of example-robot-data (URDF found through the installed package's file list), given to the
workflow with a massless flange (wrist_3_link's inertia zeroed, as the TX40's published URDF has it: the
URDF's mass matrix is singular). The true plant differs from that URDF by
- link inertial errors: each of links 1-5 scaled (mass and inertia about its COM) by 1 +- U(10 %, 30 %);
- motors behind gears (ratio 101) with rotor inertia, Coulomb and viscous friction on every motor, of the
  magnitudes published for a 5-kg-payload industrial arm (FIGAROH's TX40 identification: Coulomb
  2-8 N*m, viscous 0.6-8 N*m*s/rad, reflected rotor inertia 0.01-0.36 kg*m^2 on the joint side);
- a coupled wrist (default): motor 6 turns with q5 + q6, so its inertia and friction act on q5 + q6.
Simulation: pinocchio, mass matrix (crba) plus the motors' reflected inertia T^T diag(J_m) T, solved
directly (pinocchio's armature is diagonal, the coupled wrist's is not, so not `pin.aba`), friction
linearly implicit at the step's midpoint velocity, semi-implicit Euler at the log rate (5 kHz). Coulomb
friction is -tau_c tanh(dq / 0.01 rad/s) on the motor's joint-side velocity, as the plant-effects library.
Controller: computed torque from the URDF (massless flange) along a Fourier-series excitation (the standard
identification trajectory) plus joint PD; the drives apply the commanded currents. The log records what a
real arm logs: motor encoder positions (quantised), motor velocities and measured motor currents (A,
sensor noise), with the transmission and torque constants in the sidecar (`torque_kind: measured`).
`truth.json` names every hidden effect with its parameters, `true_plant.json` is the same truth as a
plant-effects file (link scales as `link_inertia` errors); the workflow reads neither.
"""

from __future__ import annotations

import json
import os
import xml.etree.ElementTree as ET
from dataclasses import asdict, dataclass, field, replace
from importlib import metadata
from pathlib import Path

import numpy as np
import pinocchio as pin

from sparc_quad.effects import EFFECTS, Effect
from sparc_quad.effects.plant import PlantEffects
from sparc_quad.gap.robot import Robot
from sparc_quad.gap.synth import Excitation

JOINTS = ["shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint", "wrist_2_joint",
          "wrist_3_joint"]
MOTORS = [f"m{i}" for i in range(1, 7)]
FLANGE_LINK = "wrist_3_link"
URDF_OUT = "ur5_massless_flange.urdf"


@dataclass
class ArmCase:
    """What the synthetic arm hides (SI; friction and inertia of motor i given on the joint side, i.e.
    what motor i shows through its gear on the velocity it turns with)."""
    gear_ratios: tuple[float, ...] = (101.0,) * 6
    torque_constants_nm_per_a: tuple[float, ...] = (0.125, 0.125, 0.125, 0.092, 0.092, 0.092)
    coulomb_nm: tuple[float, ...] = (7.0, 8.0, 5.0, 2.5, 2.0, 1.5)
    viscous_nm_s_rad: tuple[float, ...] = (8.0, 5.5, 2.0, 1.1, 1.2, 0.6)
    rotor_inertia_kg_m2: tuple[float, ...] = (0.36, 0.36, 0.1, 0.03, 0.04, 0.011)
    coupled_wrist: bool = True  # motor 6 turns with q5 + q6
    link_error_range: tuple[float, float] = (0.10, 0.30)  # |relative error| of links 1-5's inertia
    current_noise_a: float = 0.02  # 1 sigma per sample, sensor noise on the logged current
    encoder_counts_per_rev: int = 2**17  # motor side
    friction_smoothing_rad_s: float = 0.01  # joint-side velocity scale of tanh, as PlantEffects
    rate_hz: float = 5000.0
    bandwidth_hz: float = 10.0  # joint PD bandwidth of the controller
    q0: tuple[float, ...] = (0.0, -1.2, 1.4, -1.6, -1.5, 0.0)  # excitation centre, rad
    amp_rad: tuple[float, ...] = (1.0, 0.5, 0.7, 1.0, 1.0, 1.5)  # excitation amplitude per joint
    vel_fraction: float = 0.7  # excitation peak speed <= this x the URDF's velocity limit
    harmonics: int = 5
    link_scale: dict = field(default_factory=dict)  # filled from the seed: link name -> scale


def example_robot_data_urdf(name: str = "ur5_robot.urdf") -> Path:
    """A URDF shipped by the installed example-robot-data package (its file list, no hard-coded path)."""
    try:
        files = metadata.files("example-robot-data") or []
    except metadata.PackageNotFoundError as exc:
        raise RuntimeError("example-robot-data is not installed (pip install example-robot-data)") from exc
    for f in files:
        if f.name == name and "robots" in f.parts:
            return Path(f.locate())
    raise RuntimeError(f"example-robot-data has no {name}")


def write_massless_flange_urdf(out: Path, src: Path | None = None) -> Path:
    """Copy of the UR5 URDF with the flange link's inertial zeroed (mass 0, inertia 0)."""
    src = src or example_robot_data_urdf()
    tree = ET.parse(src)
    link = tree.getroot().find(f"link[@name='{FLANGE_LINK}']")
    inertial = link.find("inertial")
    inertial.find("mass").set("value", "0.0")
    for k in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz"):
        inertial.find("inertia").set(k, "0.0")
    path = out / URDF_OUT
    tree.write(path, xml_declaration=True, encoding="utf-8")
    return path


def transmission_matrix(case: ArmCase) -> np.ndarray:
    """T with q_motor = T q_joint (rad/rad); motor 6 turns with q5 + q6 on a coupled wrist."""
    T = np.diag(np.asarray(case.gear_ratios, float))
    if case.coupled_wrist:
        T[5, 4] = case.gear_ratios[5]
    return T


class ArmPlant:
    """The true arm: rigid bodies + motors seen through T. Joint-side motor parameters are converted to
    the motor side once (J_m = I / N^2, F_c,m = tau_c / N, F_v,m = b / N^2), so that with a diagonal T the
    joint sees exactly rotor_inertia / coulomb_friction / viscous_friction of the plant-effects library."""

    def __init__(self, model, case: ArmCase):
        self.model, self.data = model, model.createData()
        self.T = transmission_matrix(case)
        n = np.asarray(case.gear_ratios, float)
        self.jm = np.asarray(case.rotor_inertia_kg_m2) / n**2
        self.fc = np.asarray(case.coulomb_nm) / n
        self.fv = np.asarray(case.viscous_nm_s_rad) / n**2
        self.eps_m = case.friction_smoothing_rad_s * n  # motor-side velocity scale
        self.B = self.T.T @ np.diag(self.jm) @ self.T  # reflected rotor inertia, joint side

    def friction(self, dq: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Joint-side friction torque T^T f_m(T dq) (opposes motion) and its Jacobian d/d dq."""
        w = self.T @ dq
        th = np.tanh(w / self.eps_m)
        f = -(self.fc * th + self.fv * w)
        slope = -(self.fc * (1.0 - th**2) / self.eps_m + self.fv)
        return self.T.T @ f, self.T.T @ (slope[:, None] * self.T)

    def step(self, q, dq, tau, dt) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """One semi-implicit Euler step with joint torque `tau` held; friction at the midpoint velocity,
        linearised: f(dq) + df (dq' - dq) / 2. Returns (q', dq', ddq)."""
        M = pin.crba(self.model, self.data, q)  # the upper triangle is what pinocchio guarantees
        M = np.triu(M) + np.triu(M, 1).T + self.B
        h = pin.rnea(self.model, self.data, q, dq, np.zeros_like(dq))
        f, df = self.friction(dq)
        ddq = np.linalg.solve(M - 0.5 * dt * df, tau - h + f)
        dq1 = dq + dt * ddq
        return q + dt * dq1, dq1, ddq


def true_model(nominal, case: ArmCase):
    """The URDF's model with links 1-5 scaled by case.link_scale (mass and inertia about the COM)."""
    model = nominal.copy()
    for name, s in case.link_scale.items():
        jid = _joint_of_link(nominal, name)
        link_inertia = model.inertias[jid]
        model.inertias[jid] = pin.Inertia(s * link_inertia.mass, link_inertia.lever, s * link_inertia.inertia)
    return model


def _joint_of_link(model, link: str) -> int:
    return model.frames[model.getFrameId(link)].parentJoint


def excitation(robot: Robot, case: ArmCase, period_s: float, rng: np.random.Generator) -> Excitation:
    """Fourier series (H harmonics of 1 / period_s) per joint, scaled to the joint's amplitude and then,
    if needed, down to `vel_fraction` of its velocity limit."""
    h = np.arange(1, case.harmonics + 1)[:, None]
    a = rng.normal(size=(case.harmonics, 6)) / h
    b = rng.normal(size=(case.harmonics, 6)) / h
    q0 = np.asarray(case.q0, float)
    ex = Excitation(q0, a, b, period_s)
    t = np.linspace(0.0, period_s, 4000, endpoint=False)
    q, dq, _ = ex(t)
    scale = np.asarray(case.amp_rad) / np.max(np.abs(q - q0), axis=0)
    vmax = case.vel_fraction * np.asarray(robot.model.velocityLimit)
    scale = np.minimum(scale, vmax / (np.max(np.abs(dq), axis=0) + 1e-12))
    ex.a, ex.b = a * scale, b * scale
    return ex


def simulate(robot: Robot, plant: ArmPlant, case: ArmCase, ex: Excitation, duration_s: float,
             rng: np.random.Generator) -> dict:
    """Closed-loop run at case.rate_hz. Returns joint-side truth (q, dq, ddq, tau applied) and the
    motor-side log (q_motor quantised, dq_motor, measured current)."""
    dt = 1.0 / case.rate_hz
    n = round(duration_s * case.rate_hz)
    t = np.arange(n) * dt
    q_d, dq_d, ddq_d = ex(t)
    ff = Robot.rnea(robot.model, q_d, dq_d, ddq_d)  # the URDF (massless flange), no friction, no rotors
    m = np.diag(pin.crba(robot.model, robot.model.createData(), ex.q0)) + np.diag(plant.B)
    w = 2 * np.pi * case.bandwidth_hz
    kp, kd = m * w**2, 1.4 * m * w
    T = plant.T
    kt = np.asarray(case.torque_constants_nm_per_a, float)
    T_inv = np.linalg.inv(T)
    lsb = 2 * np.pi / case.encoder_counts_per_rev
    Q, DQ, DDQ, TAU = (np.empty((n, 6)) for _ in range(4))
    q, dq = q_d[0].copy(), dq_d[0].copy()
    for k in range(n):
        qm_meas = np.round(T @ q / lsb) * lsb
        q_meas = T_inv @ qm_meas
        tau = ff[k] + kp * (q_d[k] - q_meas) + kd * (dq_d[k] - dq)
        Q[k], DQ[k], TAU[k] = q, dq, tau
        q, dq, DDQ[k] = plant.step(q, dq, tau, dt)
        if not np.all(np.isfinite(q)):
            raise RuntimeError(f"synthetic arm diverged at t={t[k]:.4f} s")
    current = np.linalg.solve(T.T, TAU.T).T / kt  # tau_joint = T^T (kt * i)
    return {"t": t, "q": Q, "dq": DQ, "ddq": DDQ, "tau": TAU,
            "q_motor": np.round(Q @ T.T / lsb) * lsb, "dq_motor": DQ @ T.T,
            "current_a": current + rng.normal(scale=case.current_noise_a, size=current.shape)}


def sidecar(case: ArmCase, urdf_rel: str, period_s: float, description: str, motor_side: bool) -> dict:
    meta = {"urdf": urdf_rel, "actuated_joints": JOINTS, "fixed_joints": {}, "gravity": [0.0, 0.0, -9.81],
            "ee_frame": "tool0", "rate_hz": case.rate_hz, "period_s": period_s, "torque_kind": "measured",
            "description": description}
    if motor_side:
        T = transmission_matrix(case)
        meta["transmission"] = {"motors": MOTORS, "motor_to_joint": (np.linalg.inv(T) + 0.0).tolist(),
                                "torque_constants_nm_per_a": list(case.torque_constants_nm_per_a),
                                "zero_offsets_rad": [0.0] * 6}
    return meta


def write_log(path: Path, run: dict, case: ArmCase, meta: dict, motor_side: bool, with_dq: bool) -> Path:
    """Motor side: q_<motor> (rad), dq_<motor> (rad/s), tau_meas_<motor> (A, measured current).
    Joint side: q_<joint>, dq_<joint>, tau_meas_<joint> (N*m = T^T kt * measured current).
    Written under temporary names and renamed: a failure leaves no half-written trial."""
    kt = np.asarray(case.torque_constants_nm_per_a, float)
    if motor_side:
        names, q, dq, tau = MOTORS, run["q_motor"], run["dq_motor"], run["current_a"]
    else:
        T = transmission_matrix(case)
        names, q, dq = JOINTS, run["q"], run["dq"]
        tau = (run["current_a"] * kt) @ T
    header = ["t", *(f"q_{m}" for m in names)]
    blocks = [run["t"][:, None], q]
    if with_dq:
        header += [f"dq_{m}" for m in names]
        blocks.append(dq)
    header += [f"tau_meas_{m}" for m in names]
    blocks.append(tau)
    tmp_csv, tmp_json = path.with_suffix(".csv.part"), path.with_suffix(".json.part")
    np.savetxt(tmp_csv, np.hstack(blocks), delimiter=",", header=",".join(header), comments="", fmt="%.10g")
    tmp_json.write_text(json.dumps(meta, indent=2) + "\n")
    os.replace(tmp_csv, path)
    os.replace(tmp_json, path.with_suffix(".json"))
    return path


def draw_link_errors(robot: Robot, case: ArmCase, rng: np.random.Generator) -> dict:
    lo, hi = case.link_error_range
    links = [robot.child_link(j) for j in JOINTS[:5]]
    return {name: float(1.0 + rng.choice([-1.0, 1.0]) * rng.uniform(lo, hi)) for name in links}


def truth(robot: Robot, case: ArmCase) -> dict:
    """Every hidden effect, named as the plant-effects library names them (motor 6 of a coupled wrist as
    coupled_rotor_inertia / coupled_coulomb_friction / coupled_viscous_friction along q5 + q6)."""
    hidden = []
    motors_alone = range(6) if not case.coupled_wrist else range(5)
    for i in motors_alone:
        j = JOINTS[i]
        hidden += [{"name": "coulomb_friction", "joint": j, "params": {"tau_c_nm": case.coulomb_nm[i]}},
                   {"name": "viscous_friction", "joint": j,
                    "params": {"b_nm_s_rad": case.viscous_nm_s_rad[i]}},
                   {"name": "rotor_inertia", "joint": j,
                    "params": {"inertia_kg_m2": case.rotor_inertia_kg_m2[i]}}]
    if case.coupled_wrist:  # motor 6, listed with wrist_3_joint, turns with s = q5 + q6
        u = [0.0, 0.0, 0.0, 0.0, 1.0, 1.0]
        hidden += [{"name": "coupled_rotor_inertia", "joint": JOINTS[5],
                    "params": {"direction": u, "inertia_kg_m2": case.rotor_inertia_kg_m2[5]}},
                   {"name": "coupled_coulomb_friction", "joint": JOINTS[5],
                    "params": {"direction": u, "tau_c_nm": case.coulomb_nm[5]}},
                   {"name": "coupled_viscous_friction", "joint": JOINTS[5],
                    "params": {"direction": u, "b_nm_s_rad": case.viscous_nm_s_rad[5]}}]
    for link, s in case.link_scale.items():
        jid = _joint_of_link(robot.model, link)
        mass = robot.model.inertias[jid].mass
        hidden.append({"name": "link_inertia_error", "link": link, "joint": robot.model.names[jid],
                       "params": {"scale": s, "mass_kg_urdf": mass, "mass_kg_true": s * mass}})
    return {"hidden": hidden, "massless_link": FLANGE_LINK,
            "friction_smoothing_rad_s": case.friction_smoothing_rad_s,
            "transmission_q_motor_from_q_joint": transmission_matrix(case).tolist(),
            "case": {k: v for k, v in asdict(case).items() if k != "link_scale"}}


def synth_arm(out: str | Path, *, seed: int = 0, n_trials: int = 3, periods: int = 2, period_s: float = 1.5,
              case: ArmCase | None = None, motor_side: bool = True, with_dq: bool = True) -> dict:
    """Write `n_trials` trials (each `periods` repeats of its own excitation) into `out`; the workflow
    holds out the last one. Returns {"trials": [csv paths], "truth": dict, "urdf": path}."""
    if n_trials < 1 or periods < 1 or not period_s > 0:
        raise ValueError(f"need n_trials >= 1, periods >= 1, period_s > 0 (got {n_trials}, {periods}, "
                         f"{period_s})")
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    case = replace(case) if case is not None else ArmCase()  # a copy: the drawn link errors go into it
    rng = np.random.default_rng(seed)
    urdf = write_massless_flange_urdf(out)
    robot = Robot(urdf, JOINTS, {}, (0.0, 0.0, -9.81), "tool0")
    if not case.link_scale:
        case.link_scale = draw_link_errors(robot, case, rng)
    plant = ArmPlant(true_model(robot.model, case), case)
    paths = []
    for i in range(n_trials):
        ex = excitation(robot, case, period_s, rng)
        run = simulate(robot, plant, case, ex, periods * period_s, rng)
        side = "motor side (encoders, currents)" if motor_side else "joint side"
        meta = sidecar(case, URDF_OUT, period_s,
                       f"gap synth-arm seed {seed} trial {i}: UR5 with massless flange, "
                       f"{'coupled' if case.coupled_wrist else 'uncoupled'} wrist, {side}", motor_side)
        paths.append(write_log(out / f"arm_{i:02d}.csv", run, case, meta, motor_side, with_dq))
    tru = truth(robot, case) | {"seed": seed, "motor_side": motor_side}
    (out / "truth.json").write_text(json.dumps(tru, indent=2) + "\n")
    true_plant(robot, tru).save(out / "true_plant.json")
    return {"trials": paths, "truth": tru, "urdf": urdf, "true_plant": out / "true_plant.json"}


def true_plant(robot: Robot, truth_: dict) -> PlantEffects:
    """The truth as a plant-effects file (never read by `gap`): the motors' effects as named, and each
    link's scale as `link_inertia` errors of its standard dynamic parameters (all ten scale together)."""
    effects = [Effect(e["name"], e["joint"], e["params"]) for e in truth_["hidden"]
               if e["name"] in EFFECTS]
    for e in truth_["hidden"]:
        if e["name"] == "link_inertia_error":
            jid = _joint_of_link(robot.model, e["link"])
            pi = robot.model.inertias[jid].toDynamicParameters()
            effects += [Effect("link_inertia", robot.model.names[jid],
                               {"param_index": i, "delta": float((e["params"]["scale"] - 1.0) * pi[i])})
                        for i in range(10) if pi[i] != 0.0]
    return PlantEffects(JOINTS, effects, truth_["friction_smoothing_rad_s"])


def joint_effect_torque(truth_: dict, q: np.ndarray, dq: np.ndarray, ddq: np.ndarray,
                        dt: float) -> np.ndarray:
    """Joint torque of the named hidden effects alone (no rigid bodies), from truth.json: what a test adds
    to the URDF's inverse dynamics. Each motor acts along its direction u (a unit joint vector, or
    `direction` of a coupled effect) with velocity s = u . dq; friction at the step's linearised midpoint
    velocity, as `ArmPlant.step`."""
    eps = truth_["friction_smoothing_rad_s"]
    keys = {"rotor_inertia": "inertia_kg_m2", "coulomb_friction": "tau_c_nm",
            "viscous_friction": "b_nm_s_rad"}
    motors: dict[tuple[float, ...], dict] = {}
    for e in truth_["hidden"]:
        name = e["name"].removeprefix("coupled_")
        if name not in keys:
            continue
        u = e["params"].get("direction") or list(np.eye(len(JOINTS))[JOINTS.index(e["joint"])])
        motors.setdefault(tuple(u), {})[keys[name]] = e["params"][keys[name]]
    out = np.zeros_like(q)
    for u, p in motors.items():
        u = np.asarray(u)
        v, a = dq @ u, ddq @ u
        tau_c, b = p.get("tau_c_nm", 0.0), p.get("b_nm_s_rad", 0.0)
        th = np.tanh(v / eps)
        f, slope = -(tau_c * th + b * v), -(tau_c * (1 - th**2) / eps + b)
        out += (p.get("inertia_kg_m2", 0.0) * a - f - 0.5 * dt * slope * a)[:, None] * u
    return out


def link_scaled_model(robot: Robot, truth_: dict):
    """The URDF's model with the truth's link inertial errors applied."""
    case = ArmCase(link_scale={e["link"]: e["params"]["scale"] for e in truth_["hidden"]
                               if e["name"] == "link_inertia_error"})
    return true_model(robot.model, case)
