"""The quadruped sim as the robot side of the spine interface: the spine node computes the spine torques.

Per 1 ms tick `NodeSpine` publishes what the robot would: the torso state from the estimator emulation
(q1, q̇1, q̈1 valid), its heartbeat and the torso computer's spine command every 10 ms (impedance mode with
the run's gains), then the motor feedback of q2..q4 (quantised like CyberGear frames); it then takes the
node's motor command answering that tick and turns it into joint torques as a motor does
(τ = τ_ff + k_p (q_des − q) + k_d (q̇_des − q̇); zero when disabled or when no command came for 20 ms).

- `NodeSpine.inprocess(...)`: the node runs in this process on the in-process bus, ticked in lockstep;
- `NodeSpine.over_lcm(...)`: the node is another process (`sparc-quad spine-node --motors lcm`); lockstep
  waits for the answer to each tick (deterministic), real time takes whatever command is newest.

The ports are the bench robot's (`sparc_quad.sim.bench_robot`), so the quadruped and the bench spine speak
the same interface through the same code.
"""

from __future__ import annotations

import logging
import time

import numpy as np

from sparc_quad.sim.bench_robot import InProcessRobotPort, LcmRobotPort, RobotPort, states_arrays
from sparc_quad.sim.spine_drive import SpineGains, TaskKinematics
from spine_module import params as P
from spine_module.buses.base import MotorCommand, MotorFeedback
from spine_module.buses.inprocess import InProcessBus, InProcessLink
from spine_module.messages import Heartbeat, Mode, SpineCommand, SpineState, TorsoState
from spine_module.node import Controllers, NodeConfig, SpineNode
from spine_module.node.io import InProcessNodeIO

log = logging.getLogger("sparc_quad.quad_node_link")


def _quantise(v, lsb: float) -> np.ndarray:
    return np.round(np.asarray(v, dtype=float) / lsb) * lsb


class NodeSpine:
    """`spine(est, q_spine, dq_spine, t) -> tau` for `run_bound`, through the spine node."""

    name = "node"

    def __init__(self, port: RobotPort, gains: SpineGains, friction: bool = False,
                 node: SpineNode | None = None, node_io: InProcessNodeIO | None = None,
                 lockstep: bool = True, dt_s: float = P.CONTROL_PERIOD_S, lockstep_timeout_s: float = 2.0,
                 heartbeat_period_s: float = 0.010, command_period_s: float = 0.010,
                 command_timeout_s: float = 0.020) -> None:
        self.port, self.node, self.node_io = port, node, node_io
        self.lockstep = lockstep
        self.dt = dt_s
        self.timeout = lockstep_timeout_s
        self.hb_every = max(1, round(heartbeat_period_s / dt_s))
        self.cmd_every = max(1, round(command_period_s / dt_s))
        self.command_timeout = command_timeout_s
        self.command = SpineCommand(mode=Mode.IMPEDANCE, x_d=np.array(P.X_EQUILIBRIUM, dtype=float),
                                    k=np.array(gains.k, dtype=float), d=np.array(gains.d, dtype=float),
                                    friction_compensation=friction)
        self.k = 0
        self._hb_seq = 0
        self._cmd_seq = 0
        self.last_cmd: MotorCommand | None = None
        self._cmd_t: float | None = None
        self.tau = np.zeros(3)
        self.kinematics = TaskKinematics()
        self.x = self.kinematics.x
        self.unanswered = 0
        self.sent_q1: list[float] = []  # the q1 published each tick (what the node must have used)
        self._final_states: list[SpineState] | None = None

    # -- construction --------------------------------------------------------------------------------
    @classmethod
    def inprocess(cls, gains: SpineGains, friction: bool = False, node_config: NodeConfig | None = None,
                  **kw) -> NodeSpine:
        link, io = InProcessLink(), InProcessNodeIO()
        node = SpineNode(Controllers.default(), InProcessBus(link), io, node_config)
        return cls(InProcessRobotPort(link, io), gains, friction, node=node, node_io=io, **kw)

    @classmethod
    def over_lcm(cls, gains: SpineGains, friction: bool = False, url: str = "", lockstep: bool = True,
                 wait_node_s: float = 30.0, **kw) -> NodeSpine:
        port = LcmRobotPort(url)
        deadline = time.monotonic() + wait_node_s
        while not port.node_heartbeats():  # tick 0 must not be published into the void
            if time.monotonic() > deadline:
                port.close()
                raise TimeoutError(f"no heartbeat from a spine node within {wait_node_s:.1f} s")
            time.sleep(0.01)
        return cls(port, gains, friction, lockstep=lockstep, **kw)

    # -- one tick ------------------------------------------------------------------------------------
    def __call__(self, est, q_spine, dq_spine, t_sim: float) -> np.ndarray:
        k = self.k
        t = k * round(self.dt * 1e6) * 1e-6  # robot time, exact in microseconds as on the wire
        port = self.port
        port.publish_torso(TorsoState(q1=float(est.q1), dq1=float(est.dq1), ddq1=float(est.ddq1),
                                      ddq1_valid=True, stamp_s=t, seq=k))
        self.sent_q1.append(float(est.q1))
        if k % self.hb_every == 0:
            port.publish_heartbeat(Heartbeat(sender="quad-robot", stamp_s=t, seq=self._hb_seq))
            self._hb_seq += 1
        if k % self.cmd_every == 0:
            self.command.stamp_s, self.command.seq = t, self._cmd_seq
            port.publish_command(self.command)
            self._cmd_seq += 1
        s = P.SENSORS
        q = np.asarray(q_spine, dtype=float)
        dq = np.asarray(dq_spine, dtype=float)
        fb = MotorFeedback(q=_quantise(q, s.position_lsb_rad), dq=_quantise(dq, s.velocity_lsb_rad_s),
                           tau=_quantise(self.tau, s.torque_lsb_nm), temperature_c=np.full(3, 30.0),
                           mode=np.full(3, 2, dtype=np.int32), stamp_s=t, seq=k)
        port.publish_feedback(fb)
        if self.node is not None:
            self.node.tick(t, self.node.receive(0.0))
            cmd = port.take_command(0.0, want_seq=k)
        elif self.lockstep:
            cmd = port.take_command(self.timeout, want_seq=k)
        else:
            cmd = port.take_command(0.0, want_seq=None)
        if cmd is None:
            self.unanswered += 1
            if self.lockstep and self.unanswered in (1, 10, 100):
                log.warning("tick %d: no answer from the spine node", k)
        else:
            self.last_cmd, self._cmd_t = cmd, t
        c = self.last_cmd
        fresh = self._cmd_t is not None and t - self._cmd_t <= self.command_timeout
        if c is not None and c.enable and fresh:
            self.tau[:] = c.torque(q, dq)
        else:
            self.tau[:] = 0.0
        np.clip(self.tau, -P.TORQUE_LIMIT_NM, P.TORQUE_LIMIT_NM, out=self.tau)
        self.kinematics.update(np.concatenate(([est.q1], q)), np.concatenate(([est.dq1], dq)))
        self.k += 1
        return self.tau

    @property
    def task_pose(self) -> np.ndarray:
        return self.x

    @property
    def drive(self):  # for run_bound's metrics: the driver's name
        return self

    def states(self) -> list[SpineState]:
        """The node's spine states received so far (in process: all; over LCM: those that arrived)."""
        if self._final_states is not None:
            return self._final_states
        if self.node_io is not None:
            return list(self.node_io.states)
        if isinstance(self.port, LcmRobotPort):
            t_end = time.monotonic() + 0.3
            while time.monotonic() < t_end:
                self.port.lc.handle_timeout(20)
            return list(self.port.states)
        return []

    def states_arrays(self) -> dict[str, np.ndarray]:
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

