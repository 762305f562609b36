"""A node with a fake controller on an in-process link, driven tick by tick in lockstep (node time =
tick x 1 ms), so fault injection is deterministic and every deadline is read off the node's own stamps."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from spine_module import params as P
from spine_module.buses.base import MotorFeedback
from spine_module.buses.inprocess import InProcessBus, InProcessLink
from spine_module.messages import Heartbeat, Mode, SpineCommand, TorsoState
from spine_module.node import Controllers, InProcessNodeIO, NodeConfig, SpineNode
from spine_module.safety import SafetyConfig

DT = 0.001


class FakeController:
    """Records gains and targets; returns a fixed torque."""

    def __init__(self, tau=(0.5, -0.5, 0.25)) -> None:
        self.tau = np.array(tau, dtype=float)
        self.k = self.d = self.x_d = None
        self.ok = True
        self.raises = False
        self.steps = 0

    def set_gains(self, k=None, d=None):
        self.k, self.d = np.array(k, dtype=float), np.array(d, dtype=float)

    def set_target(self, x_d=None, dx_d=None, ddx_d=None):
        self.x_d = np.array(x_d, dtype=float)

    def step(self, q, dq, ddq1=0.0, base_accel=None):
        self.steps += 1
        self.last_input = (float(ddq1), None if base_accel is None else np.array(base_accel, dtype=float))
        if self.raises:
            raise RuntimeError("boom")
        return SimpleNamespace(tau=self.tau.copy() if self.ok else np.zeros(3), ok=self.ok,
                               error=None if self.ok else "bad input", x=P.X_EQUILIBRIUM.copy(),
                               dx=np.zeros(3))


class Harness:
    def __init__(self, safety: SafetyConfig | None = None, ctrl: FakeController | None = None,
                 command: SpineCommand | None = None) -> None:
        self.ctrl = ctrl or FakeController()
        self.link = InProcessLink()
        self.io = InProcessNodeIO()
        cfg = NodeConfig(safety=safety or SafetyConfig())
        ctrls = Controllers(impedance=self.ctrl, pd=self.ctrl)
        self.node = SpineNode(ctrls, InProcessBus(self.link), self.io, cfg)
        self.k = 0
        self.q = P.Q_EQUILIBRIUM[1:].copy()
        self.dq = np.zeros(3)
        self.command = command if command is not None else SpineCommand(mode=Mode.IMPEDANCE)
        self.states = []
        self.commands = []
        self.send_torso = self.send_feedback = self.send_heartbeat = self.send_command = True

    @property
    def t(self) -> float:
        return self.k * DT

    def step(self, n: int = 1, extra=None):
        for _ in range(n):
            t = self.t
            if self.send_heartbeat and self.k % 10 == 0:
                self.io.send_heartbeat(Heartbeat("test-robot", stamp_s=t, seq=self.k))
            if self.send_torso:
                self.io.send_torso(TorsoState(stamp_s=t, seq=self.k))
            if self.send_command and self.k % 10 == 0:
                self.command.stamp_s, self.command.seq = t, self.k
                self.io.send_command(self.command)
            if extra is not None:
                extra(self)
            if self.send_feedback:
                fb = MotorFeedback(q=self.q.copy(), dq=self.dq.copy(), tau=np.zeros(3), stamp_s=t, seq=self.k)
                self.link.robot.publish_feedback(fb)
            s = self.node.tick(t, self.node.receive(0.0))
            got = self.link.robot.take_command(0.0)
            self.states.append(s)
            self.commands.append(got[0] if got else None)
            self.k += 1
        return self.states[-1]

    def first(self, pred, after: float = -1.0):
        """First state (after node time `after`) satisfying pred."""
        for s in self.states:
            if s.stamp_s > after and pred(s):
                return s
        return None
