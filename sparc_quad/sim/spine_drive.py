"""What drives the spine joints in the quadruped sim, one class per spine variant of the stiffness study:

- `impedance`: the SPARC impedance controller rendered by the motors (in process, fed by the emulated
  estimator's q1); its torque is actuator work.
- `passive`: an ideal spring-damper with the same K, D acting in task space (tau = J^T F on q2..q4, no
  gravity or inertia compensation): a physical spring, so its torque is not actuator work.
- `rigid`: the spine locked by pybullet constraints (the world does it); no torque here.
- `rigid-impedance`: the impedance controller at K = 1e4 N/m; its holding torque is actuator work.

Every drive has `step(q, dq, ddq1, base_accel=None) -> tau` (base_accel: the base joint origin's linear
acceleration in the hind-body frame, m/s^2, a float64 array of 3 or None for none; only the impedance law
uses it), `x`, `dx` (task pose, rate), `ok`, `name`, `actuated`
(whether its torque is charged as actuator work), `backend` (the controller's per-step code, None for no
controller) and `energy_j` (stored in a passive element, J); each subclasses `SpineDrive`, which declares
the optional clocked members. `ScheduledDrive` adds the authors' gain switch and a slower control rate
(zero-order hold) to any drive that has `set_gains`.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from sparc_quad.sim.control_clock import ControlClock
from spine_module import params as P


@dataclass(frozen=True)
class SpineGains:
    k: tuple[float, float, float] = tuple(P.K_DEFAULT)  # k_x N/m, k_z N/m, k_theta N*m/rad
    d: tuple[float, float, float] = tuple(P.D_DEFAULT)  # d_x N*s/m, d_z N*s/m, d_theta N*m*s/rad


SPINE_VARIANTS = ("impedance", "passive", "rigid", "rigid-impedance")
SPINE_TIMINGS = ("hold", "authors")


class SpineDrive:
    """The members every drive shares beyond `step`, with their defaults: a drive runs at every physics
    step (`clocked` False, `tick()` True, `update` is `step`). A clocked drive (`ScheduledDrive`) runs only
    where `tick()` says; a caller that fills q and dq only then calls `tick` and `update` itself."""

    clocked = False

    def step(self, q: np.ndarray, dq: np.ndarray, ddq1: float, base_accel=None) -> np.ndarray:
        raise NotImplementedError

    def tick(self) -> bool:
        return True

    def update(self, q: np.ndarray, dq: np.ndarray, ddq1: float, base_accel=None) -> np.ndarray:
        return self.step(q, dq, ddq1, base_accel)


class LockedSpine(SpineDrive):
    """Rigid spine: the joints are locked by the world's constraints (`WorldConfig.lock_spine`); this
    drive applies no torque and only reports the (constant) task pose."""

    name = "rigid"
    actuated = False
    backend = None
    energy_j = 0.0

    def __init__(self) -> None:
        self.tau = np.zeros(3)
        self.kinematics = TaskKinematics()
        self.x, self.dx = self.kinematics.x, self.kinematics.dx
        self.ok = True

    def step(self, q: np.ndarray, dq: np.ndarray, ddq1: float, base_accel=None) -> np.ndarray:
        self.kinematics.update(q, dq)
        return self.tau


class TaskKinematics:
    """The spine's task pose and velocity (x, z, theta in the hind-body frame) from `SpineModel`, for
    drives that run no task controller of their own. `x` and `dx` are updated in place."""

    def __init__(self, spine: P.SpineParams | None = None) -> None:
        from spine_module.model import SpineModel

        self.model = SpineModel() if spine is None else SpineModel(spine)
        self.data = self.model.create_data()
        self.x, self.dx = self.data.x, self.data.dx

    def update(self, q: np.ndarray, dq: np.ndarray) -> None:
        self.model.update_kinematics(self.data, np.asarray(q, dtype=float), np.asarray(dq, dtype=float))


class PassiveSpine(SpineDrive):
    """An ideal spring-damper between the bodies: F = K (x_d - x) - D dx in task space, tau = J^T F, plus
    (`preload`) a constant joint torque tau_0 = g(q_eq): the spine links' own weight at the level
    equilibrium arch, as a spring designed with its rest length set for that load would carry.

    No inertia, friction or state-dependent gravity compensation: what a physical, pre-tensioned spring of
    the same K, D would apply. Both parts are conservative (the damper dissipates), so this element is
    passive; `energy_j` is its stored energy 1/2 e^T K e - tau_0 . (q - q_eq).
    """

    name = "passive"
    actuated = False
    backend = None

    def __init__(self, gains: SpineGains, x_d: tuple[float, float, float] | None = None,
                 preload: bool = True) -> None:
        self.kinematics = TaskKinematics()
        model = self.kinematics.model
        q_eq = np.array(P.Q_EQUILIBRIUM, dtype=float)
        self.q_eq = q_eq[1:].copy()
        self.tau0 = model.gravity(model.create_data(), q_eq)[1:].copy() if preload else np.zeros(3)
        self.x, self.dx = self.kinematics.x, self.kinematics.dx
        self.K = np.array(gains.k, dtype=float)
        self.D = np.array(gains.d, dtype=float)
        self.x_d = np.array(P.X_EQUILIBRIUM if x_d is None else x_d, dtype=float)
        self.tau = np.zeros(3)
        self.err = np.zeros(3)
        self.energy_j = 0.0
        self.ok = True

    def set_gains(self, k=None, d=None, x_d=None) -> None:
        if k is not None:
            self.K[:] = k
        if d is not None:
            self.D[:] = d
        if x_d is not None:
            self.x_d[:] = x_d

    def step(self, q: np.ndarray, dq: np.ndarray, ddq1: float, base_accel=None) -> np.ndarray:
        self.kinematics.update(q, dq)
        e = self.err
        np.subtract(self.x_d, self.x, out=e)
        e[2] = (e[2] + np.pi) % (2 * np.pi) - np.pi
        f = self.K * e - self.D * self.dx
        self.tau[:] = self.kinematics.data.J_act.T @ f + self.tau0
        self.energy_j = 0.5 * float(e @ (self.K * e)) - float(self.tau0 @ (np.asarray(q[1:]) - self.q_eq))
        return self.tau


class ImpedanceSpine(SpineDrive):
    """The SPARC impedance controller (spine_module.control) driving the spine in process.

    backend: "pinocchio" (the reference path; no numba loaded) or "numba" (the compiled step, equal to the
    reference to ~1e-12, ~15x cheaper per step but ~0.7 s of CPU to load per process); a bound run picks
    it with `bound.backend.resolve_backend`.
    """

    name = "impedance"
    actuated = True
    energy_j = 0.0

    def __init__(self, gains: SpineGains, friction: bool = False, backend: str = "pinocchio",
                 spine: P.SpineParams | None = None):
        from spine_module.control import ImpedanceController, StribeckFriction
        from spine_module.model import SpineModel

        model = SpineModel() if spine is None else SpineModel(spine)
        self.ctrl = ImpedanceController(
            model, friction=StribeckFriction.nominal() if friction else None, backend=backend
        )
        self.backend = self.ctrl.backend
        self.ctrl.set_gains(k=gains.k, d=gains.d)
        self.ctrl.set_target(x_d=tuple(P.X_EQUILIBRIUM), dx_d=(0.0, 0.0, 0.0), ddx_d=(0.0, 0.0, 0.0))
        out = self.ctrl.out  # the controller fills the same output arrays every step: no copies here
        self.tau, self.x, self.dx = out.tau, out.x, out.dx
        self.ok = True

    def set_gains(self, k=None, d=None, x_d=None) -> None:
        self.ctrl.set_gains(k=k, d=d)
        if x_d is not None:
            self.ctrl.set_target(x_d=x_d)

    def step(self, q: np.ndarray, dq: np.ndarray, ddq1: float, base_accel=None) -> np.ndarray:
        self.ok = self.ctrl.step(q, dq, ddq1, base_accel).ok
        return self.tau


@dataclass(frozen=True)
class SpineSchedule:
    """The authors' spine schedule: stiffness `k0` (None: the run's k, as their code keeps Kp through the
    switch), damping `d0` at target x `x_d0_m` until `switch_s`, then the run's gains at `x_d1_m`; the
    target z is `z_d_m` and the target pitch `theta_d_rad` throughout (0 in the authors' frame in gait A; a
    model whose frame sits elsewhere shifts z). With `switch_s` 0 and equal gains and targets it is a
    constant target (gait C's)."""

    switch_s: float = P.AUTHORS_SPINE_SWITCH_S
    k0: tuple[float, float, float] | None = None
    d0: tuple[float, float, float] = tuple(P.AUTHORS_SPINE_D_START)
    x_d0_m: float = P.AUTHORS_X_D_START_M
    x_d1_m: float = P.AUTHORS_X_D_RUN_M
    z_d_m: float = 0.0
    theta_d_rad: float = 0.0


class ScheduledDrive(SpineDrive):
    """Wraps a drive: gain/target switch at a time (optional) and a control rate below the sim's, the
    torque held between updates. `clock` (a `ControlClock`, the authors' loop): the drive runs when the
    clock calls, zero torque before its first call, the switch at the first call at or after `switch_s`;
    without it, every `hold_steps` steps from step 0."""

    clocked = True

    def __init__(self, drive, gains: SpineGains, schedule: SpineSchedule | None, hold_steps: int,
                 dt_s: float, clock: ControlClock | None = None) -> None:
        self.drive, self.gains, self.schedule = drive, gains, schedule
        self.hold = max(1, int(hold_steps))
        self.dt = dt_s
        self.clock = clock
        self.name, self.actuated, self.backend = drive.name, drive.actuated, drive.backend
        self.tau = np.zeros(3)
        self._k = 0
        self._switched = schedule is None
        if schedule is not None:
            k0 = gains.k if schedule.k0 is None else schedule.k0
            drive.set_gains(k=k0, d=schedule.d0,
                            x_d=(schedule.x_d0_m, schedule.z_d_m, schedule.theta_d_rad))

    @property
    def x(self):
        return self.drive.x

    @property
    def dx(self):
        return self.drive.dx

    @property
    def ok(self) -> bool:
        return self.drive.ok

    @property
    def energy_j(self) -> float:
        return self.drive.energy_j

    def tick(self) -> bool:
        """Advance one physics step (the gain switch when it is due); whether the drive runs at this step.
        `step` is `tick` then, when it runs, `update`; a caller that fills q and dq only when the drive
        runs calls the two itself."""
        clock = self.clock
        if clock is not None:
            run = clock.tick()
            t = clock.now_s
        else:
            run = self._k % self.hold == 0
            t = self._k * self.dt
        if not self._switched and t >= self.schedule.switch_s and (run or clock is None):
            self.drive.set_gains(k=self.gains.k, d=self.gains.d,
                                 x_d=(self.schedule.x_d1_m, self.schedule.z_d_m,
                                      self.schedule.theta_d_rad))
            self._switched = True
        self._k += 1
        return run

    def update(self, q: np.ndarray, dq: np.ndarray, ddq1: float, base_accel=None) -> np.ndarray:
        """Run the wrapped drive now (a step where `tick` said so); the torque it holds until the next."""
        self.tau[:] = self.drive.step(q, dq, ddq1, base_accel)
        return self.tau

    def step(self, q: np.ndarray, dq: np.ndarray, ddq1: float, base_accel=None) -> np.ndarray:
        if self.tick():
            self.update(q, dq, ddq1, base_accel)
        return self.tau


def make_spine_drive(gains: SpineGains, rigid: bool = False, friction: bool = False,
                     variant: str | None = None, schedule: SpineSchedule | None = None,
                     rate_hz: float | None = None, dt_s: float = P.CONTROL_PERIOD_S,
                     backend: str = "pinocchio", timing: str = "hold",
                     spine: P.SpineParams | None = None) -> SpineDrive:
    """The drive a bound uses. `variant` is one of SPINE_VARIANTS (`rigid=True` means "rigid").
    `schedule` applies to the impedance and passive springs, `rate_hz` (a controller rate below 1/dt_s)
    to the motor-rendered impedance only: a physical spring acts continuously. `timing` "hold" updates
    every round(1 / (rate_hz dt_s)) steps from step 0, "authors" on their loop's clock (`ControlClock`,
    period 1 / rate_hz). `backend` is the impedance controller's ("pinocchio" or "numba"); `spine` the
    parameters of the impedance controller's model (None: the SPARC module's)."""
    variant = "rigid" if rigid else (variant or "impedance")
    if variant not in SPINE_VARIANTS:
        raise ValueError(f"spine variant must be one of {', '.join(SPINE_VARIANTS)}, got {variant!r}")
    if timing not in SPINE_TIMINGS:
        raise ValueError(f"spine timing must be one of {', '.join(SPINE_TIMINGS)}, got {timing!r}")
    if variant == "rigid":
        return LockedSpine()
    if variant == "rigid-impedance":
        # the same controller, rate, clock and targets as the run's impedance spine, at K = 1e4 N/m
        gains = SpineGains(k=tuple(P.K_RIGID_IMPEDANCE), d=tuple(P.D_RIGID_IMPEDANCE))
        if schedule is not None:
            schedule = replace(schedule, k0=None, d0=gains.d)
        drive = ImpedanceSpine(gains, friction=friction, backend=backend, spine=spine)
        drive.name = "rigid-impedance"
    else:
        drive = PassiveSpine(gains) if variant == "passive" else ImpedanceSpine(gains, friction=friction,
                                                                                backend=backend, spine=spine)
    motor = bool(rate_hz) and variant != "passive"
    hold = max(1, round(1.0 / (rate_hz * dt_s))) if motor else 1
    clock = ControlClock(1.0 / rate_hz, dt_s) if motor and timing == "authors" else None
    if schedule is None and hold == 1 and clock is None:
        return drive
    return ScheduledDrive(drive, gains, schedule, hold, dt_s, clock)
