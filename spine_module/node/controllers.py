"""The controllers the node runs, built once and shared by every mode and every bus backend.

Each controller follows the spine-core API: `set_gains(k=(3,), d=(3,))`, `set_target(x_d, dx_d, ddx_d)`,
`step(q (4,), dq (4,), ddq1, base_accel=None (3,)) -> ControlOutput` with `tau (3,)`, `ok`, `error`, `x (3,)`,
`dx (3,)`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from spine_module import params


@dataclass
class Controllers:
    impedance: Any  # eq. (3); eq. (4) friction compensation switched by its `friction_enabled`
    pd: Any  # eq. (5)
    _kin: Any = field(default=None, repr=False, kw_only=True)

    @property
    def spine(self) -> params.SpineParams:
        """The spine the controllers model (the SPARC module's for a controller without a model)."""
        return getattr(getattr(self.impedance, "model", None), "spine", params.DEFAULT_SPINE)

    def task_state(self, q: np.ndarray, dq: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Task pose and velocity by forward kinematics, for modes that run no task controller."""
        model = getattr(self.impedance, "model", None)
        if model is None:
            return np.full(3, np.nan), np.full(3, np.nan)
        if self._kin is None:
            self._kin = model.create_data()
        model.update_kinematics(self._kin, q, dq)
        return self._kin.x.copy(), self._kin.dx.copy()

    @classmethod
    def default(cls, spine: params.SpineParams = params.DEFAULT_SPINE) -> Controllers:
        from spine_module.control import ImpedanceController, StribeckFriction, TaskPDController
        from spine_module.model import SpineModel

        model = SpineModel(spine=spine)
        return cls(impedance=ImpedanceController(model, friction=StribeckFriction.nominal()),
                   pd=TaskPDController(model))
