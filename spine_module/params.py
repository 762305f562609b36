"""Every physical number of the SPARC spine, in SI units, in one place.

Sources: the SPARC paper (Table II actuator data, Table III link data, Section IV gains) and the
CyberGear manual for actuator limits. Where the paper is silent we make an interpretation; each one is
named `INTERPRETATION` in a comment here and is repeated in the generated URDF's comments.

Geometry (INTERPRETATION, see docs/spine.md, "The spine model"):
  universe --q1 (torso pitch, about +y)--> hind_body --q2--> hind_spine --q3--> front_spine --q4-->
  front_body --fixed--> end_effector.
  Each link extends along its own +x by Table III's length; the next joint sits at the link's tip. With
  the spine straight the end effector is 0.3614 m from the q1 axis. The paper's equilibrium
  x_d = [0.273, 0, 0] is then a symmetric arch: q2 = q4 = -a, q3 = 2a, a = acos((0.273-0.1264)/0.235)
  = 0.8963 rad, with the middle joint above the line (the spine arches up, as a dog's back does).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

GRAVITY_M_S2 = 9.81
CONTROL_RATE_HZ = 1000.0
CONTROL_PERIOD_S = 1.0 / CONTROL_RATE_HZ
HEARTBEAT_PERIOD_S = 0.010  # node -> robot and robot -> node heartbeats
SPINE_COMMAND_PERIOD_S = 0.010  # torso computer -> node spine command (the scripts of the co-simulations)
# Motor-side command timeout (the CyberGear's CAN timeout, off by default on the real motor): with no fresh
# command for this long the motors apply zero torque instead of holding a stale one.
MOTOR_COMMAND_TIMEOUT_S = 0.020


@dataclass(frozen=True)
class LinkParams:
    """One rigid link of the chain (Table III).

    `inertia_kg_m2` is (Ixx, Iyy, Izz) about the link's centre of mass in the link frame.
    """

    name: str
    mass_kg: float
    length_m: float
    inertia_kg_m2: tuple[float, float, float]
    com_x_m: float


def _com_with_actuator(mass_kg: float, length_m: float, actuator_kg: float) -> float:
    """COM along the link when an actuator's mass sits at the link's distal joint axis.

    INTERPRETATION: the paper says ~75 % of the mass is in the three actuators. Each of hind body, hind
    spine and front spine carries the stator of the actuator at its distal joint; the rest of its mass
    (printed structure) is spread uniformly along the link. The front body carries no actuator.
    """
    structure = mass_kg - actuator_kg
    return (actuator_kg * length_m + structure * 0.5 * length_m) / mass_kg


ACTUATOR_MASS_KG = 0.317  # Table II
_MM2 = 1e-6  # kg*mm^2 -> kg*m^2

HIND_BODY = LinkParams(
    "hind_body", 0.377, 0.0632, (181 * _MM2, 328 * _MM2, 228 * _MM2),
    _com_with_actuator(0.377, 0.0632, ACTUATOR_MASS_KG),
)
HIND_SPINE = LinkParams(
    "hind_spine", 0.376, 0.1175, (148 * _MM2, 502 * _MM2, 426 * _MM2),
    _com_with_actuator(0.376, 0.1175, ACTUATOR_MASS_KG),
)
FRONT_SPINE = LinkParams(
    "front_spine", 0.414, 0.1175, (991 * _MM2, 175 * _MM2, 990 * _MM2),
    _com_with_actuator(0.414, 0.1175, ACTUATOR_MASS_KG),
)
FRONT_BODY = LinkParams("front_body", 0.060, 0.0632, (44 * _MM2, 92 * _MM2, 61 * _MM2), 0.5 * 0.0632)
LINKS: tuple[LinkParams, ...] = (HIND_BODY, HIND_SPINE, FRONT_SPINE, FRONT_BODY)
MODULE_MASS_KG = sum(link.mass_kg for link in LINKS)  # 1.227 kg from Table III (paper quotes 1.26 kg)

BASE_JOINT = "q1"
ACTUATED_JOINTS: tuple[str, ...] = ("q2", "q3", "q4")
ALL_JOINTS: tuple[str, ...] = (BASE_JOINT, *ACTUATED_JOINTS)
EE_FRAME = "end_effector"

# --- Actuator: Xiaomi CyberGear (Table II and the CyberGear manual) ----------------------------------
@dataclass(frozen=True)
class CyberGearLimits:
    """The CyberGear's hardware ranges, the one copy: the CAN protocol's uint16 scaling, the motor
    config's checks, the LCM codec's motor ranges and the simulated sensors' LSBs all read them here.

    Sources: the CyberGear micromotor instruction manual (public English translation, github
    belovictor/cybergear-docs): section 1.3 (peak torque 12 N*m, peak current 23 A), 1.4 (7.75:1),
    section 4 (operation control: torque +-12 N*m, velocity +-30 rad/s, kp 0..500, kd 0..5; position
    +-4*pi in the tables, +-12.5 rad in the sample code and most drivers), and its parameter list
    (CAN_TIMEOUT 0..100000; the unit, 20000 = 1 s, is RobStride's, see buses/cybergear/protocol.py)."""

    torque_nm: float = 12.0  # peak output torque = operation-control torque range
    velocity_rad_s: float = 30.0  # operation-control / feedback velocity range
    position_rad: float = 12.5  # operation-control / feedback position range as the sample code scales it
    position_table_rad: float = 4 * math.pi  # the same range as the manual's tables give it
    kp_nm_rad: float = 500.0  # operation-control kp range
    kd_nm_s_rad: float = 5.0  # operation-control kd range
    current_a: float = 23.0  # peak phase current = iq_ref range
    gear_ratio: float = 7.75  # inside the motor: its frames are output-side
    can_timeout_ticks_per_s: int = 20_000  # CAN_TIMEOUT counts per second (50 us each)
    can_timeout_max_ticks: int = 100_000  # the parameter list's maximum (5 s)


CYBERGEAR = CyberGearLimits()
TORQUE_LIMIT_NM = CYBERGEAR.torque_nm  # peak output torque
GEAR_RATIO = CYBERGEAR.gear_ratio
VELOCITY_LIMIT_RAD_S = CYBERGEAR.velocity_rad_s  # operation-control velocity range of the CyberGear
# INTERPRETATION: the CyberGear's rotor inertia is not in the paper; 3e-5 kg*m^2 is an estimate for an
# outer-rotor motor of its size. Reflected through 7.75:1 it is 1.8e-3 kg*m^2 per joint, ten times the
# front body's own inertia about q4, so the model (pinocchio `armature`) and the plant both carry it.
ROTOR_INERTIA_KG_M2 = 3.0e-5
REFLECTED_ROTOR_INERTIA_KG_M2 = GEAR_RATIO**2 * ROTOR_INERTIA_KG_M2

# Joint limits (INTERPRETATION): keep the arch on one branch and away from the straight singularity.
JOINT_LOWER_RAD = {"q1": -math.pi, "q2": -1.75, "q3": -0.20, "q4": -1.75}
JOINT_UPPER_RAD = {"q1": math.pi, "q2": 0.20, "q3": 2.90, "q4": 0.20}
JOINT_LIMIT_MARGIN_RAD = 0.10  # the node adds damping inside this margin of a limit


def equilibrium_arch_angle(x_m: float = 0.273) -> float:
    """Arch angle a such that the symmetric arch (-a, 2a, -a) puts the end effector at x_m, z = 0."""
    inner = 2 * HIND_SPINE.length_m
    reach = x_m - HIND_BODY.length_m - FRONT_BODY.length_m
    return math.acos(reach / inner)


X_EQUILIBRIUM = np.array([0.273, 0.0, 0.0])  # (x m, z m, theta rad), Section IV-A
_A = equilibrium_arch_angle(float(X_EQUILIBRIUM[0]))
Q_EQUILIBRIUM = np.array([0.0, -_A, 2 * _A, -_A])  # (q1..q4) rad


# --- Friction (eq. 4) -------------------------------------------------------------------------------
@dataclass(frozen=True)
class StribeckParams:
    """Per-joint smooth Stribeck friction, eq. (4).

    tau = (tau_c + (tau_s - tau_c) exp(-(|dq|/dq_s)^alpha)) tanh(beta dq) + b dq
    """

    tau_c_nm: float  # Coulomb friction, N*m
    tau_s_nm: float  # static (breakaway) friction, N*m
    b_nm_s_rad: float  # viscous coefficient, N*m*s/rad
    dq_s_rad_s: float  # Stribeck velocity, rad/s
    alpha: float  # Stribeck shape exponent, dimensionless
    beta_s_rad: float  # tanh sharpness, s/rad

    def scaled(self, coulomb: float = 1.0, static: float = 1.0, viscous: float = 1.0,
               stribeck_velocity: float = 1.0) -> StribeckParams:
        """A copy with each coefficient multiplied: used to make the plant differ from the model."""
        return StribeckParams(self.tau_c_nm * coulomb, self.tau_s_nm * static, self.b_nm_s_rad * viscous,
                              self.dq_s_rad_s * stribeck_velocity, self.alpha, self.beta_s_rad)


# INTERPRETATION: the paper identifies friction but publishes no values. These are of the size reported
# for CyberGear-class QDD actuators (output side): ~0.05 N*m Coulomb, ~0.08 N*m breakaway.
NOMINAL_FRICTION = StribeckParams(tau_c_nm=0.05, tau_s_nm=0.08, b_nm_s_rad=0.010, dq_s_rad_s=0.05,
                                  alpha=2.0, beta_s_rad=50.0)

# --- Default controller settings (Section IV) -------------------------------------------------------
K_DEFAULT = np.array([500.0, 1000.0, 15.0])  # k_x N/m, k_z N/m, k_theta N*m/rad
D_DEFAULT = np.array([20.0, 20.0, 0.3])  # d_x N*s/m, d_z N*s/m, d_theta N*m*s/rad
DLS_LAMBDA = 1e-3  # damped least-squares regulariser lambda (m), small as in eq. (3)

# Bench experiments (Section IV): the commanded k_x / d_x each one sweeps; the other axes hold K_DEFAULT and
# D_DEFAULT, except d_x on the quasi-static runs (push-pull, hand-held holds), which is light
BENCH_STATIC_K_X_N_M = (300.0, 400.0, 500.0, 600.0, 700.0)  # Table IV
BENCH_PD_K_X_N_M = (300.0, 400.0, 500.0, 600.0)  # Fig. 7
BENCH_DYNAMIC_K_X_N_M = (300.0, 500.0)  # Fig. 5
BENCH_DYNAMIC_D_X_N_S_M = (0.0, 2.0, 20.0, 40.0)  # Fig. 5
BENCH_QUASI_STATIC_D_X_N_S_M = 5.0


@dataclass(frozen=True)
class SensorParams:
    """What the robot's sensors add to the truth (used by the simulated plant)."""

    # CyberGear feedback frames carry uint16 over the CYBERGEAR ranges. Position: the tables' +-4*pi (0.5 %
    # coarser than the sample code's +-12.5 rad the protocol scales with by default); with 12.5 the gap
    # workflow's test_without_repeats_uses_high_frequency_floor turns from gap_closed to
    # unexplained_residual, a verdict that sensitive to the LSB is left to that test's owners
    position_lsb_rad: float = 2 * CYBERGEAR.position_table_rad / 65535
    velocity_lsb_rad_s: float = 2 * CYBERGEAR.velocity_rad_s / 65535
    torque_lsb_nm: float = 2 * CYBERGEAR.torque_nm / 65535
    torque_noise_nm: float = 0.02  # current-based torque estimate, 1 sigma
    load_cell_noise_n: float = 0.05  # 20 kg cell + HX711 at the bench's bandwidth, 1 sigma


SENSORS = SensorParams()


@dataclass(frozen=True)
class SafetyParams:
    """Deadlines and limits of the node's safety logic."""

    torso_deadline_s: float = 0.020
    feedback_deadline_s: float = 0.005
    command_deadline_s: float = 0.200
    heartbeat_deadline_s: float = 0.100
    soft_start_s: float = 0.5
    # a feedback gap (FEEDBACK_STALE: zero torque, motors left enabled) no longer than this resumes the
    # running ramp (full gain if it had finished); a longer one, or any stop, soft-starts again
    stale_resume_s: float = 0.200
    joint_limit_damping_nm_s_rad: float = 0.5
    damping_mode_nm_s_rad: float = 0.3  # joint damping in the damping (safe) mode


SAFETY = SafetyParams()


@dataclass(frozen=True)
class SpineParams:
    """The bundle a model is built from; pass a modified copy to study a different spine."""

    links: tuple[LinkParams, ...] = LINKS
    armature_kg_m2: float = REFLECTED_ROTOR_INERTIA_KG_M2  # reflected rotor inertia, each actuated joint
    torque_limit_nm: float = TORQUE_LIMIT_NM
    velocity_limit_rad_s: float = VELOCITY_LIMIT_RAD_S
    lower_rad: dict[str, float] = field(default_factory=lambda: dict(JOINT_LOWER_RAD))
    upper_rad: dict[str, float] = field(default_factory=lambda: dict(JOINT_UPPER_RAD))


DEFAULT_SPINE = SpineParams()


# --- Spine variants of the stiffness study ----------------------------------------------------------
# "rigid-impedance": the impedance controller made stiff. k_theta = 1e4 N/m x (0.1 m)^2 is the same
# stiffness felt at a 0.1 m lever; damping near 0.2 of critical for the ~0.4 kg / ~3e-3 kg*m^2 the spine
# moves (INTERPRETATION: the study's specification names k = 1e4 only).
K_RIGID_IMPEDANCE = np.array([1.0e4, 1.0e4, 100.0])  # N/m, N/m, N*m/rad
D_RIGID_IMPEDANCE = np.array([25.0, 25.0, 0.25])  # N*s/m, N*s/m, N*m*s/rad

# The authors' bound (github YueWang996/sparc, mujoco_simulation/main_robot.py): spine impedance for the
# first 4 s, then the run's gains with the target pulled in to 0.268 m.
AUTHORS_SPINE_K = np.array([800.0, 2000.0, 15.0])  # N/m, N/m, N*m/rad (both phases)
AUTHORS_SPINE_D_START = np.array([15.0, 5.0, 1.5])  # N*s/m, N*s/m, N*m*s/rad, t < 4 s
AUTHORS_SPINE_D_RUN = np.array([8.0, 5.0, 0.5])  # after the switch
AUTHORS_SPINE_SWITCH_S = 4.0
AUTHORS_X_D_START_M = 0.273
AUTHORS_X_D_RUN_M = 0.268
AUTHORS_SPINE_RATE_HZ = 200.0


# --- Electrical losses (CoT_elec): copper loss per actuator = LOSS * tau_out^2 (W, tau in N*m) --------
@dataclass(frozen=True)
class WindingLoss:
    """Winding (I^2 R) loss of one actuator from its output-side torque constant and resistance.

    `kt_nm_per_a`: output torque per ampere of the current the datasheet quotes; `phase_resistance_ohm`;
    `loss_w_per_nm2` = 3 R_phase / kt^2 for an RMS-current kt, 1.5 R_phase / kt^2 for a peak (dq) one.
    """

    name: str
    kt_nm_per_a: float
    phase_resistance_ohm: float
    current_is_rms: bool
    source: str

    @property
    def loss_w_per_nm2(self) -> float:
        phases = 3.0 if self.current_is_rms else 1.5
        return phases * self.phase_resistance_ohm / self.kt_nm_per_a**2


# CyberGear manual §1.3: torque constant 0.87 N*m/Arms (output side), line resistance 0.45 ohm (wye:
# 0.225 ohm per phase). -> 0.89 W/(N*m)^2.
CYBERGEAR_WINDING = WindingLoss("CyberGear", 0.87, 0.45 / 2, True,
                                "Xiaomi CyberGear micromotor manual, section 1.3 electrical characteristics")
# Solo12 actuator (ODRI open_robot_actuator_hardware, actuator_module_v1 README): T-Motor Antigravity 4004
# 300 kV, Rs = 0.23255 ohm per phase (Motorware ID), motor kt 0.025 N*m/A (Grimminger et al. 2020, RA-L
# 5(2)) through the 9:1 belt drive = 0.225 N*m/A on the dq current. -> 6.9 W/(N*m)^2.
# INTERPRETATION: the sim's legs give up to 8 N*m (3x a real Solo12 actuator), so leg losses at high torque
# extrapolate this actuator beyond its range.
SOLO12_WINDING = WindingLoss("Solo12 (Antigravity 4004 300kV, 9:1)", 0.025 * 9.0, 0.23255, False,
                             "ODRI actuator_module_v1 README (Rs); Grimminger et al. 2020 (kt, 9:1)")
