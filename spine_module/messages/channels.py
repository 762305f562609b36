"""LCM channel names of the spine module (documented in docs/robot-side.md, "Channels")."""

import os

# LCM's default group and port, with a 2 MB socket receive buffer (capped by net.core.rmem_max) so a
# briefly descheduled process does not drop datagrams at 1 kHz. $LCM_DEFAULT_URL overrides it.
DEFAULT_URL = os.environ.get("LCM_DEFAULT_URL", "udpm://239.255.76.67:7667?ttl=0&recv_buf_size=2097152")

TORSO_STATE = "SPARC_TORSO_STATE"  # robot/estimator -> node, sparc.torso_state_t
SPINE_COMMAND = "SPARC_SPINE_COMMAND"  # torso computer -> node, sparc.spine_command_t
SPINE_STATE = "SPARC_SPINE_STATE"  # node -> anyone, sparc.spine_state_t
MOTOR_COMMAND = "SPARC_MOTOR_COMMAND"  # node -> simulated robot, sparc.motor_command_t
MOTOR_FEEDBACK = "SPARC_MOTOR_FEEDBACK"  # simulated robot -> node, sparc.motor_feedback_t
HEARTBEAT_NODE = "SPARC_HEARTBEAT_NODE"  # node -> robot side, sparc.heartbeat_t
HEARTBEAT_ROBOT = "SPARC_HEARTBEAT_ROBOT"  # robot side -> node, sparc.heartbeat_t

ALL = (TORSO_STATE, SPINE_COMMAND, SPINE_STATE, MOTOR_COMMAND, MOTOR_FEEDBACK, HEARTBEAT_NODE,
       HEARTBEAT_ROBOT)
