"""The spine module's on-robot LCM interface: channel names, in-memory message types, and a codec
that validates every decoded field (see `codec`). Generated LCM classes live in `lcmt/` (do not edit;
regenerate with `python -m spine_module.messages.gen`)."""

from spine_module.messages import channels
from spine_module.messages.codec import (
    FingerprintError,
    MessageError,
    decode,
    encode_command,
    encode_heartbeat,
    encode_motor_command,
    encode_motor_feedback,
    encode_state,
    encode_torso,
)
from spine_module.messages.motor import MotorCommand, MotorFeedback
from spine_module.messages.types import LATCHING, Fault, Heartbeat, Mode, SpineCommand, SpineState, TorsoState

__all__ = [
    "LATCHING",
    "Fault",
    "FingerprintError",
    "Heartbeat",
    "MessageError",
    "Mode",
    "MotorCommand",
    "MotorFeedback",
    "SpineCommand",
    "SpineState",
    "TorsoState",
    "channels",
    "decode",
    "encode_command",
    "encode_heartbeat",
    "encode_motor_command",
    "encode_motor_feedback",
    "encode_state",
    "encode_torso",
]
