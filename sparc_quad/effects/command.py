"""What the torque-on-command effects share: the size of a joint's commanded torque."""

from __future__ import annotations

import numpy as np


def abs_command(sel, joint: str) -> np.ndarray:
    """|commanded torque| of `joint` over the training blocks (N*m)."""
    ja = sel.robot.actuated.index(joint)
    return np.concatenate([np.abs(sel.lib.blocks[b].trial.tau_cmd[:, ja]) for b in sel.train])
