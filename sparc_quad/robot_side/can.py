"""The spine node with `--motors can` in one process: node -> CanMotorBus -> virtual CAN -> emulated
CyberGears (lockstep; their firmware applies `MotorCommand.torque`) -> pybullet bench spine.

`RobotSide` with the `EmulatedCyberGears` body and the `CanEmulatorPort`: torso state, robot heartbeat
and the torso computer's spine command (from the script) reach the node in process, as in the in-process
run; the motors' feedback and commands are CAN frames. CAN carries no load cell, so the rig's load cell is
logged by world time and paired with the node's states by stamp (`NodeCanRun.states_arrays`).
"""

from __future__ import annotations

import uuid
from collections.abc import Callable
from dataclasses import dataclass

import can
import numpy as np

from sparc_quad.robot_side.bodies import EmulatedCyberGears
from sparc_quad.robot_side.loop import RobotConfig, RobotSide
from sparc_quad.robot_side.ports import CanEmulatorPort
from sparc_quad.robot_side.scripts import BenchScript
from sparc_quad.robot_side.states import states_arrays
from sparc_quad.sim.bench_world import BenchWorld
from sparc_quad.sim.cybergear_bench import BenchCoupling
from sparc_quad.sim.cybergear_emulator import CyberGearEmulator
from sparc_quad.sim.plant import PlantConfig
from spine_module.buses.cybergear import CanMotorBus, load_config
from spine_module.messages import SpineState
from spine_module.node import Controllers, NodeConfig, SpineNode
from spine_module.node.io import InProcessNodeIO


@dataclass
class NodeCanRun:
    """A node run over CAN: the node's states, the rig's force log, the backend's counters."""

    states: list[SpineState]  # per tick
    t_force: np.ndarray  # world time of each logged step, s
    f_cell: np.ndarray  # load-cell reading at that step, N
    ticks: int
    bus_stats: dict
    emulator_rejected: int
    stop_frames_sent: int

    def states_arrays(self) -> dict[str, np.ndarray]:
        """The node's states as arrays with the load cell filled in from the rig's log (paired by stamp,
        NaN where the rig logged none)."""
        a = states_arrays(self.states)
        f_at = {round(t * 1e6): f for t, f in zip(self.t_force, self.f_cell, strict=True)}
        cell = np.full((len(self.states), 2), np.nan)
        cell[:, 0] = [f_at.get(round(s.stamp_s * 1e6), np.nan) for s in self.states]
        a["node_load_cell"] = cell
        return a


def run_node_over_can(script: BenchScript, node_config: NodeConfig | None = None,
                      plant: PlantConfig | None = None, seed: int = 0, controllers: Controllers | None = None,
                      n_ticks: int | None = None, config=None, channel: str | None = None,
                      robot_config: RobotConfig | None = None,
                      on_tick: Callable[[int, CyberGearEmulator], None] | None = None) -> NodeCanRun:
    """`config`: the motors' `CanConfig` (default `load_config()`); `on_tick(k, emulator)` runs before the
    node's tick k (fault injection)."""
    cfg = (config or load_config()).with_(silent_timeout_s=5.0)
    channel = channel or f"node-{uuid.uuid4().hex[:8]}"
    io = InProcessNodeIO()
    with BenchWorld(plant=plant, seed=seed) as world:
        coupling = BenchCoupling(world, cfg.ids, script.force, log_every=1)
        ebus = can.Bus(interface="virtual", channel=channel)
        emu = CyberGearEmulator(ebus, cfg.ids, coupling, lockstep=True, dt=world.dt_s, ranges=cfg.ranges)
        emu.keep_log = False
        dt_us = round(world.dt_s * 1e6)
        mb = CanMotorBus(cfg, interface="virtual", channel=channel,  # lockstep: no zero-torque hold
                         stamp_clock=lambda: coupling.steps * dt_us * 1e-6, hold_max_s=0.0)
        node = SpineNode(controllers if controllers is not None else Controllers.default(), mb, io,
                         node_config)

        def cosim(k: int, t: float) -> None:
            if on_tick is not None:
                on_tick(k, emu)
            node.tick(t, node.receive(0.5 if k else 5.0))

        robot = RobotSide(EmulatedCyberGears(coupling), CanEmulatorPort(io), script.command, robot_config,
                          cosim)
        n = n_ticks if n_ticks is not None else round(script.duration_s / world.dt_s)
        try:
            mb.start()
            robot.run_lockstep(n)
        finally:
            node.stop()
            stats = mb.stats()
            mb.shutdown()
            emu.shutdown()
            ebus.shutdown()
    return NodeCanRun(states=list(io.states), t_force=np.array(coupling.t), f_cell=np.array(coupling.f_cell),
                      ticks=n, bus_stats=stats, emulator_rejected=len(emu.rejected),
                      stop_frames_sent=stats["stop_frames_sent"])
