"""LCM channel names of the spine module (documented in docs/robot-side.md, "Channels")."""

import os

# LCM's default group and port, with a 2 MB socket receive buffer (capped by net.core.rmem_max) so a
# briefly descheduled process does not drop datagrams at 1 kHz. $LCM_DEFAULT_URL overrides it.
DEFAULT_URL = os.environ.get("LCM_DEFAULT_URL", "udpm://239.255.76.67:7667?ttl=0&recv_buf_size=2097152")
# For a lockstep co-simulation on one host (`bound --lcm` + `spine-node --motors lcm --clock lockstep`,
# both given `--lcm-url` this): LCM's multi-port provider puts each channel on its own port of the same
# group, so a process's receiving thread wakes only for the channels it subscribes to. With `udpm` every
# datagram wakes every LCM process on the host, the sender's own included (measured: 49-58 us per robot
# tick publishing against 22 us; docs/performance.md "LCM lockstep"). Not the default: a peer on `udpm`
# (lcm-logger, lcm-spy, a torso computer's own code) does not hear `mpudpm`.
COSIM_URL = "mpudpm://239.255.76.67:7667?ttl=0&recv_buf_size=2097152"

TORSO_STATE = "SPARC_TORSO_STATE"  # robot/estimator -> node, sparc.torso_state_t
SPINE_COMMAND = "SPARC_SPINE_COMMAND"  # torso computer -> node, sparc.spine_command_t
SPINE_STATE = "SPARC_SPINE_STATE"  # node -> anyone, sparc.spine_state_t
MOTOR_COMMAND = "SPARC_MOTOR_COMMAND"  # node -> simulated robot, sparc.motor_command_t
MOTOR_FEEDBACK = "SPARC_MOTOR_FEEDBACK"  # simulated robot -> node, sparc.motor_feedback_t
HEARTBEAT_NODE = "SPARC_HEARTBEAT_NODE"  # node -> robot side, sparc.heartbeat_t
HEARTBEAT_ROBOT = "SPARC_HEARTBEAT_ROBOT"  # robot side -> node, sparc.heartbeat_t

ALL = (TORSO_STATE, SPINE_COMMAND, SPINE_STATE, MOTOR_COMMAND, MOTOR_FEEDBACK, HEARTBEAT_NODE,
       HEARTBEAT_ROBOT)
