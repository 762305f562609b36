"""How a simulated bound gets its spine torques: one interface, two configurations of it.

`SimSpine` is what `run_bound` calls each step, in two halves so that a spine computed elsewhere (a node
in another process) works while the gait runs: `begin(est, q_spine, dq_spine, t)` hands over this step's
state, `finish()` returns the spine torques (N*m, q2..q4).

The reference is the spine node (`sparc_quad.robot_side.quad.NodeSpine`): the robot's own 1 kHz runner
with its soft start, joint-limit damping, torque clamp, watchdogs and E-stop, fed CyberGear-quantised
feedback through the motor model (MIT Cheetah-Software's SimulationBridge likewise always runs the
RobotRunner). `DirectSpine` is its declared fast configuration: the same controller classes called in
process, with the node's joint-limit damping and torque clamp (the function the node's tick calls,
`spine_module.safety.limit_torque`, with `SafetyConfig`'s numbers) on the motor-rendered variants. What
it leaves out is listed in `DirectSpine.SKIPS`; each item there needs a transport, a clock of its own or a
start from rest, which a simulated step handed its state in memory does not have.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Protocol, runtime_checkable

import numpy as np

from sparc_quad.sim.spine_drive import ImpedanceSpine, SpineGains, SpineSchedule, make_spine_drive
from spine_module import params as P
from spine_module import safety

_limit_torque = safety.limit_torque


@runtime_checkable
class SimSpine(Protocol):
    """The spine as a bound sees it."""

    name: str  # the configuration: "direct" | "node"
    driver: str  # what renders the spine: impedance | passive | rigid | rigid-impedance | node
    actuated: bool  # whether the spine torque is actuator work (False: a physical spring or a lock)
    backend: str | None  # the controller's per-step code ("pinocchio" | "numba"), None where not ours
    clocked: bool  # computed only at its own clock's calls, the torque held between (a bound may step
    #                the held steps in chunks); False: a torque that can change every step

    @property
    def task_pose(self) -> np.ndarray:
        """(x m, z m, theta rad) of the front body in the hind-body frame, as of the last `begin`."""
        ...

    @property
    def energy_j(self) -> float:
        """Energy stored in a passive spine element, J (0 for motor-rendered spines)."""
        ...

    def begin(self, est, q_spine: Sequence[float], dq_spine: Sequence[float], t_s: float) -> None: ...

    def finish(self) -> Sequence[float]: ...

    def node_states(self) -> dict[str, np.ndarray] | None:
        """The node's logged states (node configurations), None where there is no node."""
        ...

    def close(self) -> None: ...


class DirectSpine:
    """The spine controller called in the simulation process: the fast configuration of `SimSpine`."""

    name = "direct"
    SKIPS = (
        "soft start (the node ramps gains and target in over SafetyConfig.soft_start_s after enable)",
        "watchdogs: torso, feedback, command and heartbeat deadlines (nothing here can go stale)",
        "E-stop and the damping and disabled modes (no operator commands in a bound)",
        "CyberGear frame quantisation of q, dq, tau and the motor model (command timeout, latch)",
    )
    # `spine` (SpineParams of another robot's spine) brings its own joint and torque limits; `limits`
    # overrides both (default: the node's SafetyConfig, i.e. the SPARC module's)

    def __init__(self, gains: SpineGains, variant: str = "impedance", friction: bool = False,
                 schedule: SpineSchedule | None = None, rate_hz: float | None = None, dt_s: float = 1e-3,
                 backend: str = "pinocchio", timing: str = "hold", spine=None, torso_accel: bool = True,
                 limits: safety.SafetyConfig | None = None) -> None:
        self.drive = make_spine_drive(gains, friction=friction, variant=variant, schedule=schedule,
                                      rate_hz=rate_hz, dt_s=dt_s, backend=backend, timing=timing, spine=spine)
        self._torso_accel = torso_accel  # False: q̈1 = 0 to the spine law (the authors' controller has none)
        self.driver = self.drive.name
        self.actuated = bool(self.drive.actuated)
        self.backend = self.drive.backend
        lim = limits if limits is not None else safety.SafetyConfig()
        if spine is not None and limits is None:  # another robot's spine: its own joint and torque limits
            joints = P.ACTUATED_JOINTS
            self._limits = safety.TorqueLimits.of(
                [spine.lower_rad[j] for j in joints], [spine.upper_rad[j] for j in joints], lim.limit_margin,
                lim.joint_limit_damping, spine.torque_limit_nm)
        else:
            self._limits = safety.TorqueLimits.from_config(lim)
        self._q = np.zeros(4)
        self._dq = np.zeros(4)
        self._acc = np.zeros(3)  # the estimate's base acceleration, handed to the law as an array
        self._tau: list[float] = [0.0, 0.0, 0.0]
        # a clocked drive (`ScheduledDrive`) is filled and run only at its calls; its torque, held in
        # between, is kept here as floats
        self.clocked = bool(self.drive.clocked)
        self._tick = self.drive.tick if self.clocked else None
        self._held: list[float] = self.drive.tau.tolist() if self._tick is not None else []

    @property
    def task_pose(self) -> np.ndarray:
        return self.drive.x

    @property
    def energy_j(self) -> float:
        return self.drive.energy_j

    def begin(self, est, q_spine, dq_spine, t_s: float) -> None:
        tick = self._tick
        if tick is None or tick():
            q, dq = self._q, self._dq
            q[0], q[1], q[2], q[3] = est.q1, *q_spine  # item by item: half a slice assignment's cost
            dq[0], dq[1], dq[2], dq[3] = est.dq1, *dq_spine
            ddq1 = est.ddq1 if self._torso_accel else 0.0
            base = est.base_accel  # None: the estimate has none (WorldConfig.base_motion "fixed")
            acc = None
            if base is not None:
                acc = self._acc
                acc[0], acc[1], acc[2] = base
            if tick is None:
                tau = self.drive.step(q, dq, ddq1, acc).tolist()
            else:
                tau = self._held = self.drive.update(q, dq, ddq1, acc).tolist()
        else:
            tau = self._held
        if self.actuated:  # what the node does to a controller's torque before the motors get it
            a, b, c, _, _ = _limit_torque(tau, q_spine, dq_spine, self._limits)
            self._tau = [a, b, c]
        else:
            self._tau = tau

    def finish(self) -> list[float]:
        return self._tau

    def compiled_law(self):
        """(controller, torque limits, torso_accel) where `begin` is the compiled impedance law run every
        step, then `spine_module.safety.limit_torque` (what the bound's compiled step does in one call),
        else None."""
        drive = self.drive
        if (self.clocked or type(drive) is not ImpedanceSpine or drive.ctrl.backend != "numba"
                or self._limits.clear is None):
            return None
        return drive.ctrl, self._limits, self._torso_accel

    def node_states(self) -> None:
        return None

    def close(self) -> None:
        pass
