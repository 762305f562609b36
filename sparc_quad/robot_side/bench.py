"""The stand-in robot for the bench spine: `RobotSide` with the pybullet bench world as its body.

`BenchRobot` speaks over any port (in process, LCM); `run_inprocess` is the node and the robot in one
thread in lockstep, the reference the LCM and CAN runs are compared with.
"""

from __future__ import annotations

from collections.abc import Callable

from sparc_quad.robot_side.bodies import BenchBody
from sparc_quad.robot_side.loop import RobotConfig, RobotSide
from sparc_quad.robot_side.ports import InProcessPort, Port
from sparc_quad.robot_side.scripts import BenchScript
from sparc_quad.sim.bench_world import BenchWorld
from sparc_quad.sim.plant import PlantConfig
from spine_module.buses.inprocess import InProcessBus, InProcessLink
from spine_module.messages import SpineState
from spine_module.node import Controllers, NodeConfig, SpineNode
from spine_module.node.io import InProcessNodeIO


class BenchRobot(RobotSide):
    """The bench spine speaking the robot's side of the interface; `script` says what is commanded and
    pushed; runs default to the script's length."""

    def __init__(self, world: BenchWorld, port: Port, script: BenchScript | None = None,
                 config: RobotConfig | None = None,
                 cosim: Callable[[int, float], None] | None = None) -> None:
        self.world = world
        self.script = script if script is not None else BenchScript()
        super().__init__(BenchBody(world, self.script.force), port, self.script.command, config, cosim)

    def _n(self, n_ticks: int | None) -> int:
        return n_ticks if n_ticks is not None else round(self.script.duration_s / self.dt)

    def run_lockstep(self, n_ticks: int | None = None, stop: Callable[[], bool] | None = None) -> None:
        super().run_lockstep(self._n(n_ticks), stop)

    def run_realtime(self, n_ticks: int | None = None, stop: Callable[[], bool] | None = None) -> float:
        return super().run_realtime(self._n(n_ticks), stop)


def run_inprocess(script: BenchScript, node_config: NodeConfig | None = None,
                  plant: PlantConfig | None = None, seed: int = 0, controllers: Controllers | None = None,
                  n_ticks: int | None = None,
                  robot_config: RobotConfig | None = None) -> tuple[BenchRobot, list[SpineState]]:
    """Node and bench robot in one process, in lockstep: the reference for the LCM and CAN runs."""
    link, io = InProcessLink(), InProcessNodeIO()
    ctrls = controllers if controllers is not None else Controllers.default()
    node = SpineNode(ctrls, InProcessBus(link), io, node_config)
    with BenchWorld(plant=plant, seed=seed) as world:
        robot = BenchRobot(world, InProcessPort(link, io), script, robot_config,
                           cosim=lambda k, t: node.tick(t, node.receive(0.0)))
        robot.run_lockstep(n_ticks)
        node.stop()
    return robot, list(io.states)
