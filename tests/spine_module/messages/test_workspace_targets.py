"""Issue 31: targets the spine cannot reach are refused in the modes that act on them.

(0, 0, 0), (0.3614, 0, 0) and (0.273, 0, pi) are inside the per-coordinate ranges but pinned the joints at
their limits at 12 N*m. Both decoders (and so `spine-cmd`, which validates with them) refuse them naming
x_d in IMPEDANCE, PD and JOINT_TORQUE (whose stale fallback holds x_d), and accept them where x_d is unused.
The closed-form solution is checked against the model's forward kinematics.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from spine_module import params as P
from spine_module.messages import MessageError, Mode, SpineCommand, codec
from spine_module.model import SpineModel
from spine_module.workspace import joint_solutions, unreachable

BAD_TARGETS = [(0.0, 0.0, 0.0), (0.3614, 0.0, 0.0), (0.273, 0.0, math.pi)]
DECODERS = [codec.decode_command, codec.decode_command_checked]


@pytest.mark.parametrize("decoder", DECODERS)
@pytest.mark.parametrize("mode", [Mode.IMPEDANCE, Mode.PD, Mode.JOINT_TORQUE])
@pytest.mark.parametrize("x_d", BAD_TARGETS)
def test_unreachable_target_refused_naming_x_d(decoder, mode, x_d):
    data = codec.encode_command(SpineCommand(mode=mode, x_d=np.array(x_d)))
    with pytest.raises(MessageError, match=r"SPARC_SPINE_COMMAND\.x_d: .*(outside the workspace|beyond)"):
        decoder(data)


@pytest.mark.parametrize("mode", [Mode.DISABLED, Mode.DAMPING, Mode.ESTOP])
def test_modes_that_ignore_x_d_do_not_check_it(mode):
    for x_d in BAD_TARGETS:  # an E-stop is never refused for its unused target
        data = codec.encode_command(SpineCommand(mode=mode, x_d=np.array(x_d)))
        assert codec.decode_command(data).mode == mode


def test_the_papers_targets_are_reachable():
    assert unreachable(*P.X_EQUILIBRIUM) is None
    assert unreachable(0.268, 0.0, 0.0) is None  # the authors' run target


def test_closed_form_matches_the_models_kinematics():
    model = SpineModel()
    rng = np.random.default_rng(3)
    lo = np.array([P.JOINT_LOWER_RAD[j] for j in P.ACTUATED_JOINTS])
    hi = np.array([P.JOINT_UPPER_RAD[j] for j in P.ACTUATED_JOINTS])
    for _ in range(200):
        q = rng.uniform(lo, hi)
        x = model.task_pose(np.concatenate(([0.0], q)))
        sols = np.array(joint_solutions(*x))
        assert np.min(np.max(np.abs(sols - q), axis=1)) < 1e-9, (q, sols)


def _longer_spine() -> P.SpineParams:
    """Another host's spine: the SPARC links 20 % longer, joints over +-1.5 rad."""
    from dataclasses import replace

    return P.SpineParams(links=tuple(replace(link, length_m=1.2 * link.length_m) for link in P.LINKS),
                         lower_rad={**P.JOINT_LOWER_RAD, **dict.fromkeys(P.ACTUATED_JOINTS, -1.5)},
                         upper_rad={**P.JOINT_UPPER_RAD, **dict.fromkeys(P.ACTUATED_JOINTS, 1.5)})


def test_another_spines_workspace_is_its_own():
    """Closed form against that spine's model; a target beyond the SPARC module's reach is inside it, and
    a node running that model (its inbox) accepts it while the SPARC decoder refuses it."""
    from spine_module.messages import channels
    from spine_module.node.io import Inbox
    from spine_module.workspace import SPARC, Workspace

    spine = _longer_spine()
    ws, model = Workspace.of(spine), SpineModel(spine=spine)
    assert ws.reach_m == pytest.approx(1.2 * SPARC.reach_m)
    rng = np.random.default_rng(4)
    for _ in range(100):
        q = rng.uniform(-1.5, 1.5, 3)
        sols = np.array(ws.joint_solutions(*model.task_pose(np.concatenate(([0.0], q)))))
        assert np.min(np.max(np.abs(sols - q), axis=1)) < 1e-9, q
    target = (0.38, 0.0, 0.0)  # beyond 0.3614 m
    assert SPARC.unreachable(*target) is not None and ws.unreachable(*target) is None
    data = codec.encode_command(SpineCommand(mode=Mode.IMPEDANCE, x_d=np.array(target)))
    with pytest.raises(MessageError, match="x_d"):
        codec.decode_command(data)
    assert codec.CommandDecoder(spine).checked(data).x_d[0] == pytest.approx(0.38)
    inbox = Inbox()
    inbox.offer_bytes(channels.SPINE_COMMAND, data)
    assert inbox.command is None and inbox.rejected[channels.SPINE_COMMAND] == 1
    inbox.decode_commands_for(spine)
    inbox.offer_bytes(channels.SPINE_COMMAND, data)
    assert inbox.command is not None and inbox.command.x_d[0] == pytest.approx(0.38)
