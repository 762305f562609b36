"""The pybullet bench spine behind emulated CyberGear motors: real CAN frames between controller and physics.

`BenchCoupling` is the emulator's `Load`: motor ids map to the actuated joints q2..q4 of a `BenchWorld`;
each lockstep cycle the emulator's firmware torques step the world once, with an optional external force
law at the end effector (the bench's push-pull), and the load cell's readings are logged.

`static_trial_over_can` runs the paper's static push-pull for one commanded k_x with the controller on the
far side of a python-can bus: controller -> CanMotorBus -> frames -> emulator -> pybullet -> frames back.
The spine node over CAN is `sparc_quad.robot_side.can.run_node_over_can`.
"""

from __future__ import annotations

import uuid
from collections.abc import Iterable
from dataclasses import dataclass

import can
import numpy as np

from sparc_quad.sim.bench_world import BenchWorld
from sparc_quad.sim.cybergear_emulator import CyberGearEmulator
from sparc_quad.sim.forces import ForceLaw
from spine_module.buses.base import MotorCommand


class BenchCoupling:
    """`Load` for the emulator backed by the pybullet bench spine."""

    def __init__(self, world: BenchWorld, motor_ids: Iterable[int] = (1, 2, 3), force: ForceLaw | None = None,
                 log_every: int = 1) -> None:
        self.world = world
        self.ids = list(motor_ids)
        self.index = {m: k + 1 for k, m in enumerate(self.ids)}  # motor id -> joint index in q1..q4
        self.force = force
        self.log_every = log_every
        self.kin = world.model.create_data()
        self.steps = 0
        self.t: list[float] = []
        self.f_true: list[float] = []
        self.f_cell: list[float] = []
        self.x_true: list[np.ndarray] = []
        self._st = world.state()
        self._f_ext = np.zeros(3)

    def read(self, motor_id: int) -> tuple[float, float]:
        k = self.index[motor_id]
        return float(self._st.q[k]), float(self._st.dq[k])

    def q1(self) -> tuple[float, float]:
        return float(self._st.q[0]), float(self._st.dq[0])

    def step(self, torques: dict[int, float], dt: float) -> None:
        tau = np.array([torques.get(m, 0.0) for m in self.ids])
        fx = 0.0
        if self.force is not None:
            st = self._st
            self.world.model.update_kinematics(self.kin, st.q, st.dq)
            fx = float(self.force(self.world.time_s, self.kin.x, self.kin.dx))
            if self.steps % self.log_every == 0:
                self.t.append(self.world.time_s)
                self.f_true.append(fx)
                self.f_cell.append(self.world.load_cell(fx))
                self.x_true.append(self.kin.x.copy())
        self._f_ext[0] = fx
        self.world.step(tau, self._f_ext if fx != 0.0 else None)
        self._st = self.world.state()
        self.steps += 1


@dataclass
class CanTrialLog:
    x_meas: np.ndarray  # controller's task pose from CAN feedback, one row per logged cycle
    f_cell: np.ndarray  # load cell, N
    f_true: np.ndarray
    tau: np.ndarray  # commanded joint torques
    cycles: int
    tx_frames: int
    rx_frames: int
    emulator_rejected: int


def static_trial_over_can(controller, duration_s: float, force: ForceLaw, *, plant=None, seed: int = 0,
                          sample_every: int = 10, q0: np.ndarray | None = None, config=None,
                          channel: str | None = None) -> CanTrialLog:
    """One static trial with the controller behind the CAN backend (virtual bus, lockstep emulator)."""
    from spine_module.buses.cybergear import CanMotorBus, load_config

    cfg = (config or load_config()).with_(silent_timeout_s=5.0)
    channel = channel or f"bench-{uuid.uuid4().hex[:8]}"
    n = round(duration_s / 1e-3)
    rows = []
    with BenchWorld(plant=plant, seed=seed, q0=q0) as world:
        coupling = BenchCoupling(world, cfg.ids, force, log_every=sample_every)
        ebus = can.Bus(interface="virtual", channel=channel)
        emu = CyberGearEmulator(ebus, cfg.ids, coupling, lockstep=True, dt=world.dt_s, ranges=cfg.ranges)
        emu.keep_log = False
        try:
            with CanMotorBus(cfg, interface="virtual", channel=channel,  # lockstep: no zero-torque hold
                             stamp_clock=lambda: world.time_s, hold_max_s=0.0) as mb:
                mb.start()
                for i in range(n):
                    fb = mb.receive(timeout_s=5.0)
                    if fb is None:
                        raise RuntimeError(f"no feedback at cycle {i}")
                    q1, dq1 = coupling.q1()
                    out = controller.step(np.concatenate(([q1], fb.q)), np.concatenate(([dq1], fb.dq)))
                    if i % sample_every == 0:
                        rows.append((out.x.copy(), out.tau.copy()))
                    mb.send(MotorCommand(tau_ff=out.tau))
                tx, rx = mb.tx_frames, mb.rx_frames
        finally:
            emu.shutdown()
            ebus.shutdown()
    m = min(len(rows), len(coupling.f_cell))
    return CanTrialLog(x_meas=np.array([r[0] for r in rows[:m]]), f_cell=np.array(coupling.f_cell[:m]),
                       f_true=np.array(coupling.f_true[:m]), tau=np.array([r[1] for r in rows[:m]]),
                       cycles=n, tx_frames=tx, rx_frames=rx, emulator_rejected=len(emu.rejected))
