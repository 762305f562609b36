"""The node's in-memory messages: dataclasses with numpy arrays, SI units, seconds for time.

On the wire these are the LCM types in `lcm_types/` (microsecond `utime`); `codec` converts and validates.
Motor command and feedback are in `motor` (shared by the codec, the buses and the robot side).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import IntEnum, IntFlag

import numpy as np

from spine_module import params


class Mode(IntEnum):
    """Spine modes (spine_command_t.MODE_*)."""

    DISABLED = 0
    DAMPING = 1
    IMPEDANCE = 2
    PD = 3
    JOINT_TORQUE = 4
    ESTOP = 5


class Fault(IntFlag):
    """Fault bits of spine_state_t.faults (spine_state_t.FAULT_*)."""

    NONE = 0
    TORSO_STALE = 1
    FEEDBACK_STALE = 2
    COMMAND_STALE = 4
    HEARTBEAT_LOST = 8
    ESTOP = 16
    BAD_COMMAND = 32
    BAD_TORSO = 64
    BAD_FEEDBACK = 128
    TORQUE_CLAMPED = 256
    JOINT_LIMIT = 512
    CONTROLLER = 1024
    BUS = 2048
    WAITING = 4096
    MOTOR = 8192
    NODE_CONFLICT = 16384


LATCHING = Fault.HEARTBEAT_LOST | Fault.ESTOP | Fault.NODE_CONFLICT
MODES: tuple[Mode, ...] = tuple(sorted(Mode))  # MODES[i] is Mode(i) without the enum call (1 kHz paths)
if [int(m) for m in MODES] != list(range(len(MODES))):
    raise RuntimeError("Mode values must be 0..n-1 (MODES[i] is Mode(i))")


def _vec(values, n: int = 3) -> np.ndarray:
    return np.array(values, dtype=float).reshape(n)


@dataclass
class TorsoState:
    """State estimator output for the hind body (the spine's base)."""

    q1: float = 0.0  # rad
    dq1: float = 0.0  # rad/s
    ddq1: float = 0.0  # rad/s^2
    ddq1_valid: bool = False
    quat: np.ndarray = field(default_factory=lambda: np.array([1.0, 0.0, 0.0, 0.0]))  # w, x, y, z
    omega: np.ndarray = field(default_factory=lambda: np.zeros(3))  # rad/s, body frame
    stamp_s: float = 0.0
    seq: int = 0
    # linear acceleration of the spine model's base joint origin, hind-body frame, m/s^2, gravity not
    # included; zeros unless base_accel_valid (the node then runs the fixed-origin law)
    base_accel: np.ndarray = field(default_factory=lambda: np.zeros(3))
    base_accel_valid: bool = False


@dataclass
class SpineCommand:
    """What the torso computer asks of the spine (see spine_command_t for units)."""

    mode: Mode = Mode.IMPEDANCE
    x_d: np.ndarray = field(default_factory=lambda: params.X_EQUILIBRIUM.copy())
    dx_d: np.ndarray = field(default_factory=lambda: np.zeros(3))
    ddx_d: np.ndarray = field(default_factory=lambda: np.zeros(3))
    k: np.ndarray = field(default_factory=lambda: params.K_DEFAULT.copy())
    d: np.ndarray = field(default_factory=lambda: params.D_DEFAULT.copy())
    friction_compensation: bool = True
    tau_ff: np.ndarray = field(default_factory=lambda: np.zeros(3))
    reset: bool = False
    stamp_s: float = 0.0
    seq: int = 0


@dataclass
class Heartbeat:
    sender: str = ""
    fault: bool = False
    reset_count: int = 0
    stamp_s: float = 0.0
    seq: int = 0
    instance: int = 0  # random number the sender drew at start-up (0: none); tells two nodes apart


@dataclass
class SpineState:
    """What the node reports each tick (see spine_state_t for units)."""

    stamp_s: float = 0.0
    seq: int = 0
    mode: Mode = Mode.DISABLED
    requested_mode: Mode = Mode.DISABLED
    faults: Fault = Fault.NONE
    rejected: str = ""
    q: np.ndarray = field(default_factory=lambda: np.zeros(4))
    dq: np.ndarray = field(default_factory=lambda: np.zeros(4))
    tau_cmd: np.ndarray = field(default_factory=lambda: np.zeros(3))
    tau_est: np.ndarray = field(default_factory=lambda: np.zeros(3))
    x: np.ndarray = field(default_factory=lambda: np.zeros(3))
    dx: np.ndarray = field(default_factory=lambda: np.zeros(3))
    gain_scale: float = 0.0
    load_cell: np.ndarray = field(default_factory=lambda: np.full(2, np.nan))
    temperature: np.ndarray = field(default_factory=lambda: np.zeros(3))
    period: float = 0.0
    jitter_max: float = 0.0
    compute: float = 0.0
    feedback_seq: int = -1
    command_seq: int = -1
    torso_seq: int = -1
