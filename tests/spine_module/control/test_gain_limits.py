"""The gain bound of `spine_module.control.gain_limits`: its constant and its claim.

- MOBILITY_MAX is at least the largest (J M^-1 J^T)_ii found on 2000 random poses of the joint ranges;
- gains that use the whole STABILITY_BUDGET leave the linearised three-axis loop (exact task inertia of the
  pose, semi-implicit Euler at the node's period) stable on random poses and random splits of the budget;
- the gains issue 31 saw chatter (d_theta = 5, or k = 0 with every d at the interface's maximum) are
  refused, and do make that loop unstable at some pose; the paper's and the authors' gains are accepted.
"""

from __future__ import annotations

import numpy as np
import pytest

from spine_module import params as P
from spine_module.control.gain_limits import MOBILITY_MAX, STABILITY_BUDGET, stability_use, unstable_gains
from spine_module.model import SpineModel

LO = np.array([P.JOINT_LOWER_RAD[j] for j in P.ACTUATED_JOINTS])
HI = np.array([P.JOINT_UPPER_RAD[j] for j in P.ACTUATED_JOINTS])


def _mobility(model: SpineModel, data, q: np.ndarray) -> np.ndarray:
    qq = np.concatenate(([0.0], q))
    model.update_kinematics(data, qq, np.zeros(4))
    M = model.mass_matrix(data, qq)[1:, 1:]
    J = data.J[:, 1:]
    return J @ np.linalg.solve(M, J.T)


def _radius(minv: np.ndarray, k, d, t: float) -> float:
    kk, dd, eye = np.diag(k), np.diag(d), np.eye(3)
    a = np.block([[eye - t * t * minv @ kk, t * (eye - t * minv @ dd)],
                  [-t * minv @ kk, eye - t * minv @ dd]])
    return float(np.max(np.abs(np.linalg.eigvals(a))))


@pytest.fixture(scope="module")
def poses():
    model = SpineModel()
    data = model.create_data()
    rng = np.random.default_rng(11)
    return [_mobility(model, data, rng.uniform(LO, HI)) for _ in range(2000)]


def test_mobility_constant_bounds_every_pose(poses):
    worst = np.max([np.diag(m) for m in poses], axis=0)
    assert np.all(worst <= np.array(MOBILITY_MAX)), worst


@pytest.mark.parametrize("rate_hz", [1000.0, 100.0])
def test_gains_within_the_budget_keep_the_loop_stable(poses, rate_hz):
    t = 1.0 / rate_hz
    rng = np.random.default_rng(5)
    for minv in poses[::10]:
        w = rng.dirichlet(np.ones(6))  # the budget split between the six gains
        mob = np.array(MOBILITY_MAX)
        d = w[:3] * STABILITY_BUDGET / (2 * t * mob)
        k = w[3:] * STABILITY_BUDGET / (t * t * mob)
        assert stability_use(k, d, t) == pytest.approx(STABILITY_BUDGET)
        assert _radius(minv, k, d, t) < 1.0


def test_the_chattering_gains_are_refused_and_do_chatter(poses):
    t = 1e-3
    for k, d in (((500.0, 1000.0, 15.0), (20.0, 20.0, 5.0)), ((0.0, 0.0, 0.0), (200.0, 200.0, 10.0))):
        assert unstable_gains(k, d, 1000.0) is not None
        assert max(_radius(m, k, d, t) for m in poses) > 1.0
    for k, d in ((P.K_DEFAULT, P.D_DEFAULT), (P.AUTHORS_SPINE_K, P.AUTHORS_SPINE_D_START),
                 (P.K_RIGID_IMPEDANCE, P.D_RIGID_IMPEDANCE)):
        assert unstable_gains(k, d, 1000.0) is None


def test_the_node_refuses_gains_it_cannot_render_and_keeps_the_last_command():
    from spine_module.messages import Fault, Mode, SpineCommand
    from tests.node_harness import Harness

    h = Harness(command=SpineCommand(mode=Mode.DAMPING))
    h.step(20)
    h.command = SpineCommand(mode=Mode.IMPEDANCE, d=np.array([20.0, 20.0, 5.0]))
    s = h.step(5)
    assert s.requested_mode == Mode.DAMPING and s.faults & Fault.BAD_COMMAND
    assert "gains not renderable at 1000 Hz" in s.rejected


def test_spine_cmd_refuses_them_before_sending(capsys):
    from sparc_quad.cli import main

    assert main(["spine-cmd", "--lcm-url", "memq://", "--mode", "impedance", "--dth", "10"]) == 2
    assert "gains not renderable" in capsys.readouterr().err
    assert main(["spine-cmd", "--lcm-url", "memq://", "--mode", "impedance"]) == 0
