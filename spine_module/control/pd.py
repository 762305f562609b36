"""Task-space PD, eq. (5): tau = J_taskᵀ (D(ẋ_d − ẋ) + K(x_d − x)).

No inertia, Coriolis, gravity or friction cancellation: the paper's lighter baseline. Only the task
Jacobian is needed.
"""

from __future__ import annotations

import numpy as np

from spine_module.control.output import ControlOutput, TaskController


class TaskPDController(TaskController):
    def step_reference(self, q: np.ndarray, dq: np.ndarray, ddq1: float = 0.0,
                       base_accel: np.ndarray | None = None) -> ControlOutput:
        """The pinocchio path (reference and fallback). ddq1 and base_accel are accepted and unused (no
        dynamics in eq. 5)."""
        try:
            self.model.update_kinematics(self.data, q, dq)
            np.matmul(self.data.J.T, self._spring_damper(), out=self._tau_full)
        except Exception:  # wrong shapes or types: name the input, never raise in the loop
            return self._fail(self.check_state(q, dq, ddq1) or "controller failed on this input")
        return self._finish(self._tau_full, q, dq, 0.0)
