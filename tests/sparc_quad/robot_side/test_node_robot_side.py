"""The robot side's safety (like SPARC's PMU): when the node's heartbeat is lost the bench robot latches a
fault and applies zero torque until the node asks for a reset; and an in-process node run equals the lead's
bench rig when the node adds nothing (soft start off, no limits or clamps hit)."""

from __future__ import annotations

import numpy as np
import pytest

from sparc_quad.experiments import rig
from sparc_quad.experiments.scripts import hold_script
from sparc_quad.robot_side.bench import BenchRobot, run_inprocess
from sparc_quad.robot_side.ports import InProcessPort
from sparc_quad.sim.bench_world import BenchWorld
from spine_module.buses.inprocess import InProcessBus, InProcessLink
from spine_module.messages import Mode
from spine_module.model import SpineModel
from spine_module.node import Controllers, InProcessNodeIO, SpineNode
from spine_module.params import SAFETY


def test_robot_latches_on_lost_node_heartbeat_until_reset():
    """Also: the robot's motor-command timeout zeroes torque 20 ms after the node goes silent."""
    link, io = InProcessLink(), InProcessNodeIO()
    node = SpineNode(Controllers.default(), InProcessBus(link), io)
    with BenchWorld() as world:
        robot = BenchRobot(world, InProcessPort(link, io), hold_script(10.0))

        def tick(node_alive: bool):
            t = robot.publish_tick()
            if node_alive:
                node.tick(t, node.receive(0.0))
            robot.finish_tick(robot.port.take_command(0.0, want_seq=None))

        for _ in range(600):
            tick(True)
        assert not robot.latched and node.state.mode == Mode.IMPEDANCE and robot.log.tau[-1].any()
        t_dead = robot.now() - robot.dt  # last tick the node ran (and sent its heartbeat, every 10 ms)
        for _ in range(150):
            tick(False)
        lat = np.array(robot.log.latched)
        t = np.array(robot.log.t)
        taus = np.array(robot.log.tau)
        dead = t > t_dead
        first_zero = t[dead][np.argmax(~taus[dead].any(axis=1))]
        # the motors' command timeout acts first: zero torque 20 ms after the last command
        assert first_zero - t_dead == pytest.approx(robot.cfg.command_timeout_s + robot.dt, abs=1.5e-3)
        first = t[np.argmax(lat)]
        assert lat.any() and first - t_dead <= SAFETY.heartbeat_deadline_s + 0.010 + robot.dt + 1e-9
        assert not np.array(robot.log.tau)[np.argmax(lat):].any()  # zero torque once latched
        for _ in range(100):
            tick(True)  # node back: heartbeat fresh, but the latch holds
        assert robot.latched and not robot.log.tau[-1].any()
        robot.script.command.reset = True
        for _ in range(10):
            tick(True)
        robot.script.command.reset = False
        for _ in range(10):
            tick(True)
        assert not robot.latched and robot.log.tau[-1].any() and node.safety.reset_count >= 1


def test_inprocess_node_equals_rig_without_soft_start():
    from spine_module.node import NodeConfig
    from spine_module.safety import SafetyConfig

    script = hold_script(0.3)
    _, states = run_inprocess(script, NodeConfig(safety=SafetyConfig(soft_start_s=0.0)), n_ticks=300)
    model = SpineModel()
    ctrl = rig.make_controller("impedance", model, tuple(script.command.k), tuple(script.command.d))
    log = rig.run(ctrl, 0.3)
    np.testing.assert_allclose(np.array([s.x for s in states]), log.x_meas, rtol=0, atol=1e-12)
    assert np.array([s.tau_cmd for s in states]) == pytest.approx(log.tau, abs=1e-12)


def test_inprocess_bus_hands_over_copies_that_share_no_arrays():
    from spine_module.buses.base import MotorCommand, MotorFeedback
    from spine_module.buses.inprocess import InProcessBus, InProcessLink

    link = InProcessLink()
    bus = InProcessBus(link)
    fb = MotorFeedback(q=np.ones(3), dq=np.ones(3), tau=np.ones(3), seq=4)
    link.robot.publish_feedback(fb)
    fb.q[:] = 9.0  # the robot reuses its buffer
    got = bus.receive(0.0)
    assert isinstance(got, MotorFeedback) and got.seq == 4 and np.all(got.q == 1.0)
    cmd = MotorCommand(tau_ff=np.full(3, 0.5))
    bus.send(cmd)
    cmd.tau_ff[:] = -1.0
    taken, _ = link.robot.take_command(0.0)
    assert isinstance(taken, MotorCommand) and np.all(taken.tau_ff == 0.5)
