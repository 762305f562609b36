"""The paper's control laws: impedance (eq. 3), Stribeck friction compensation (eq. 4), task PD (eq. 5)."""

from spine_module.control.friction import StribeckFriction
from spine_module.control.impedance import ImpedanceController
from spine_module.control.output import ControlOutput, TaskController
from spine_module.control.pd import TaskPDController

__all__ = ["ControlOutput", "ImpedanceController", "StribeckFriction", "TaskController", "TaskPDController"]
