"""Names of the operating regimes a residual is split by (`workflow.localise` makes the masks, `report`
plots them): a module of its own so the report does not import the workflow that calls it."""

from __future__ import annotations

REGIMES = ("near_zero_velocity", "velocity_reversal", "high_acceleration", "high_torque", "slow_drift")
