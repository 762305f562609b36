"""The robot's side of the spine interface, once: one loop (`RobotSide`) between a `Body` (bench world,
quadruped world, emulated CyberGears) and a `Port` (in-process, LCM, CAN via the emulator).

The shape is python-can's `BusABC` + backends and Cheetah-Software's one `RobotRunner` between a
simulation and a hardware bridge: the loop owns the schedule, stamps, motor model and watchdog; bodies and
ports only move numbers. `BenchRobot`, `NodeSpine`, `run_node_over_can` and the bench rig are
configurations of it (`configs`).
"""

from sparc_quad.robot_side.bodies import Body
from sparc_quad.robot_side.loop import RobotConfig, RobotLog, RobotSide
from sparc_quad.robot_side.motors import MotorModel, as_frame
from sparc_quad.robot_side.ports import InProcessPort, LcmPort, Port
from sparc_quad.robot_side.scripts import BenchScript, ForceLaw, push_pull
from sparc_quad.robot_side.watchdog import HeartbeatWatchdog

__all__ = ["BenchScript", "Body", "ForceLaw", "HeartbeatWatchdog", "InProcessPort", "LcmPort", "MotorModel",
           "Port", "RobotConfig", "RobotLog", "RobotSide", "as_frame", "push_pull"]
