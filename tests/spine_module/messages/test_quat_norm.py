"""Issue 31: the torso quaternion's norm check is the same at every orientation.

The docs promise "unit norm +-10 %, renormalised". Each element used to be bounded to [-1, 1] first, so a
level quaternion of norm 1.05 (w = 1.05) was refused while the same norm pitched 90 deg was accepted.
Both decoders (the fast one and the field-by-field reference) must accept norms 0.95 and 1.05 at level and
at 90 deg pitch, return the unit quaternion, and refuse 0.85 and 1.15 naming `quat`.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from spine_module.messages import MessageError, codec
from spine_module.messages.lcmt.sparc import torso_state_t

LEVEL = (1.0, 0.0, 0.0, 0.0)
PITCH_90 = (math.cos(math.pi / 4), 0.0, math.sin(math.pi / 4), 0.0)  # 90 deg about y


def _torso(quat) -> bytes:
    m = torso_state_t()
    m.utime, m.seq, m.q1 = 1000, 1, 0.0
    m.quat = [float(a) for a in quat]
    m.omega, m.base_accel = [0.0] * 3, [0.0] * 3
    return m.encode()


DECODERS = [codec.decode_torso, codec.decode_torso_checked]


@pytest.mark.parametrize("decoder", DECODERS)
@pytest.mark.parametrize("orientation", [LEVEL, PITCH_90], ids=["level", "pitch90"])
@pytest.mark.parametrize("norm", [0.95, 1.05, 0.905, 1.095])
def test_near_unit_quaternion_is_renormalised_at_any_orientation(decoder, orientation, norm):
    got = decoder(_torso(np.array(orientation) * norm))
    assert np.allclose(got.quat, orientation, atol=1e-12)
    assert math.isclose(float(np.linalg.norm(got.quat)), 1.0, abs_tol=1e-12)


@pytest.mark.parametrize("decoder", DECODERS)
@pytest.mark.parametrize("orientation", [LEVEL, PITCH_90], ids=["level", "pitch90"])
@pytest.mark.parametrize("norm", [0.85, 1.15, 0.0])
def test_quaternion_off_unit_by_more_than_10_percent_is_refused(decoder, orientation, norm):
    with pytest.raises(MessageError, match="quat"):
        decoder(_torso(np.array(orientation) * norm))
