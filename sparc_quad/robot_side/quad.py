"""The quadruped sim as the robot side of the spine interface: the spine node computes the spine torques.

`NodeSpine` is `run_bound`'s reference `SimSpine`: each `begin`/`finish` pair is one `RobotSide` tick
with the quadruped's spine as the body (torso state from the estimator emulation with q̈1 valid and, when
the world's `base_motion` gives one, the base acceleration valid; the
run's impedance command every 10 ms, feedback as CyberGear frames, the node's answer through the motor
model).

- `NodeSpine.inprocess(...)`: the node runs in this process on the in-process bus, ticked in lockstep;
- `NodeSpine.over_lcm(...)`: the node is another process (`sparc-quad spine-node --motors lcm`); lockstep
  waits for the answer to each tick (deterministic), real time takes whatever command is newest.
"""

from __future__ import annotations

import numpy as np

from sparc_quad.robot_side.bodies import QuadBody
from sparc_quad.robot_side.loop import RobotConfig, RobotSide
from sparc_quad.robot_side.ports import InProcessPort, LcmPort, Port
from sparc_quad.robot_side.states import states_arrays
from sparc_quad.sim.quadruped_world import EstimatorOutput
from sparc_quad.sim.spine_drive import SpineGains, SpineSchedule, TaskKinematics
from spine_module import params as P
from spine_module.buses.inprocess import InProcessBus, InProcessLink
from spine_module.messages import Mode, SpineCommand, SpineState
from spine_module.node import Controllers, NodeConfig, SpineNode
from spine_module.node.io import InProcessNodeIO


class NodeSpine:
    """The reference `SimSpine` (`sparc_quad.sim.sim_spine`): the spine torques of a bound come from the
    spine node, its safety logic included."""

    name = "node"
    driver = "node"
    actuated = True  # motor-rendered
    backend = None  # the node's own choice
    clocked = False  # the node's torque can change every tick (soft start, limits, watchdogs)
    energy_j = 0.0

    def __init__(self, port: Port, gains: SpineGains, friction: bool = False,
                 node: SpineNode | None = None, node_io: InProcessNodeIO | None = None,
                 lockstep: bool = True, dt_s: float = P.CONTROL_PERIOD_S,
                 config: RobotConfig | None = None, schedule: SpineSchedule | None = None,
                 spine: P.SpineParams | None = None, torso_accel: bool = True) -> None:
        """`schedule`: the authors' gain switch, sent as spine commands (the first ones carry k0, d0, x_d0;
        from `switch_s` the run's gains and x_d1, at the next command period). `spine`: the model the
        logged task pose uses (and an in-process node's controllers). `torso_accel` False sends q̈1 = 0."""
        self.port, self.node, self.node_io = port, node, node_io
        self.lockstep = lockstep
        self.body = QuadBody(dt_s)
        self.gains, self.friction, self.schedule = gains, friction, schedule
        self._switched = schedule is None
        if schedule is None:
            command = self._command(gains.k, gains.d, P.X_EQUILIBRIUM)
        else:
            command = self._command(gains.k if schedule.k0 is None else schedule.k0, schedule.d0,
                                    (schedule.x_d0_m, schedule.z_d_m, schedule.theta_d_rad))
        self._torso_accel = torso_accel
        cosim = (lambda k, t: node.tick(t, node.receive(0.0))) if node is not None else None
        self.robot = RobotSide(self.body, port, command,
                               config if config is not None else RobotConfig(name="quad-robot"), cosim)
        self.kinematics = TaskKinematics(spine)
        self.x = self.kinematics.x
        self._q = np.zeros(4)
        self._final_states: list[SpineState] | None = None

    def _command(self, k, d, x_d) -> SpineCommand:
        return SpineCommand(mode=Mode.IMPEDANCE, x_d=np.array(x_d, dtype=float), k=np.array(k, dtype=float),
                            d=np.array(d, dtype=float), friction_compensation=self.friction)

    @classmethod
    def inprocess(cls, gains: SpineGains, friction: bool = False, node_config: NodeConfig | None = None,
                  **kw) -> NodeSpine:
        link, io = InProcessLink(), InProcessNodeIO()
        spine = kw.get("spine")
        controllers = Controllers.default() if spine is None else Controllers.default(spine)
        node = SpineNode(controllers, InProcessBus(link), io, node_config)
        return cls(InProcessPort(link, io), gains, friction, node=node, node_io=io, **kw)

    @classmethod
    def over_lcm(cls, gains: SpineGains, friction: bool = False, url: str = "", lockstep: bool = True,
                 wait_node_s: float = 30.0, spin_s: float = 0.0, node_states: bool = False,
                 **kw) -> NodeSpine:
        """`spin_s`: how long a lockstep wait for the node's answer polls before it blocks (0: at once).
        `node_states`: also receive the node's spine states (SPARC_SPINE_STATE, every tick) and keep them
        for `node_states()`. Off by default: each state wakes LCM's receiving thread in this process, beside
        the simulation, and on the 2-vCPU machine measured that cost the robot process ~30 % of its CPU
        time per tick (docs/performance.md, "LCM lockstep"); `lcm-logger` records them outside it.
        ValueError for a `spine` other than the SPARC module's: `spine-node` runs that model, and would
        render another host's spine with the wrong links and masses."""
        if kw.get("spine") not in (None, P.DEFAULT_SPINE):
            raise ValueError("the spine node process models the SPARC module's spine; another spine model "
                             "runs only in process (spine_path node)")
        spine = cls(LcmPort(url, keep_states=node_states, spin_s=spin_s), gains, friction, lockstep=lockstep,
                    **kw)
        if not spine.robot.wait_for_node(wait_node_s):  # tick 0 must not be published into the void
            spine.port.close()
            raise TimeoutError(f"no heartbeat from a spine node within {wait_node_s:g} s")
        return spine

    def begin(self, est, q_spine, dq_spine, t_sim: float) -> None:
        """First half of a tick: publish it to the node. Whatever needs only this tick's state (here the
        task kinematics; in `run_bound` the gait) runs before `finish`, while a node in another process
        computes the answer."""
        if not self._switched and t_sim >= self.schedule.switch_s:
            sch = self.schedule
            self.robot.command = self._command(self.gains.k, self.gains.d,
                                               (sch.x_d1_m, sch.z_d_m, sch.theta_d_rad))
            self._switched = True
        if not self._torso_accel:
            est = EstimatorOutput(est.q1, est.dq1, 0.0, est.base_accel)
        self.body.set(est, q_spine, dq_spine)
        self.robot.publish_tick()
        self._q[0] = est.q1
        self._q[1:] = self.body.q
        self.kinematics.model.update_pose(self.kinematics.data, self._q)  # x only: what is logged

    def finish(self) -> np.ndarray:
        """Second half: take the node's answer, let the motors apply it; the spine torques (N*m)."""
        self.robot.finish_tick(*self.robot.answer(self.lockstep))
        return self.body.tau

    @property
    def unanswered(self) -> int:
        return self.robot.unanswered

    @property
    def sent_q1(self) -> list[float]:
        """The q1 published each tick (what the node must have used)."""
        return self.robot.log.columns.get("sent_q1", [])

    @property
    def task_pose(self) -> np.ndarray:
        return self.x

    def states(self) -> list[SpineState]:
        """The node's spine states received so far (in process: all; over LCM: those that arrived)."""
        if self._final_states is not None:
            return self._final_states
        if self.node_io is not None:
            return list(self.node_io.states)
        if self.records_states:  # over LCM, asked for
            return self.port.drain_states(0.3)
        return []

    @property
    def records_states(self) -> bool:
        """Whether this spine sees the node's states (in process: always; over LCM: when asked for)."""
        return self.node_io is not None or (isinstance(self.port, LcmPort) and self.port.keep_states)

    def node_states(self) -> dict[str, np.ndarray] | None:
        """The node's states as arrays with the q1 the robot sent each tick (`robot_sent_q1`); None over
        LCM when the states were not received (`over_lcm(node_states=False)`, the default)."""
        if not self.records_states:
            return None
        st = self.states()
        out = states_arrays(st) if st else {}
        out["robot_sent_q1"] = np.array(self.sent_q1)
        return out

    def close(self) -> None:
        if self._final_states is not None:
            return
        self._final_states = self.states()
        if self.node is not None:
            self.node.stop()
            self.node = None
        self.port.close()
