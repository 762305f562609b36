"""Motor buses: one interface (`MotorBus`), one backend per transport."""

from spine_module.buses.base import MotorBus, MotorBusError, MotorCommand, MotorFeedback

__all__ = ["MotorBus", "MotorBusError", "MotorCommand", "MotorFeedback"]
