"""The one interface between the spine node and its motors, in the style of python-can's `BusABC`.

A backend moves `MotorCommand`s out and `MotorFeedback` in; everything above it (controller, safety,
node) is the same object whatever the transport: in-process coupling to a simulator, LCM to a simulated
robot, or CyberGear frames on a CAN bus.

All quantities are on the joint (output) side of the gearbox, in the joint's sign convention.
"""

from __future__ import annotations

from abc import ABC, abstractmethod

from spine_module.messages.motor import MotorCommand, MotorFeedback

__all__ = ["MotorBus", "MotorBusError", "MotorCommand", "MotorFeedback", "MotorSetupError"]


class MotorBusError(RuntimeError):
    """A transport failure the node must turn into its safe state (bus-off, send error, lost motor)."""


class MotorSetupError(MotorBusError):
    """The motors as wired cannot be run safely (e.g. two motors answer as one CAN id): the user must fix
    the robot, not retry; the CLI exits 2 with this message."""


class MotorBus(ABC):
    """Send commands to and receive feedback from the spine's motors.

    `receive(timeout_s)` returns the newest feedback not yet returned, or None when none arrived within
    the timeout; a lockstep node blocks on it, a real-time node polls with timeout 0. `send` never blocks
    the control loop. Backends raise `MotorBusError` for transport faults.
    """

    joint_names: tuple[str, ...] = ("q2", "q3", "q4")

    def start(self, timeout_s: float = 1.0) -> None:  # noqa: B027 - optional hook
        """Handshake with the motors; raise MotorBusError naming any that did not answer."""

    @abstractmethod
    def send(self, command: MotorCommand) -> None: ...

    @abstractmethod
    def receive(self, timeout_s: float | None = 0.0) -> MotorFeedback | None: ...

    def stop(self) -> None:
        """Command zero torque / stopped motors. Must be safe to call more than once."""
        self.send(MotorCommand.zero(len(self.joint_names), enable=False))

    def shutdown(self) -> None:  # noqa: B027 - optional hook
        """Release the transport."""

    def __enter__(self) -> MotorBus:
        return self

    def __exit__(self, *exc: object) -> None:
        try:
            self.stop()
        finally:
            self.shutdown()
