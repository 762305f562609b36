"""The layout of a bound run's log row (timeseries.csv): shared by the run (`bound_run`) that writes it and
the metrics (`sparc_quad.metrics`) that read it, so neither imports the other."""

from __future__ import annotations

LEGS = ("HL", "HR", "FL", "FR")
LEG_JOINTS = tuple(f"{leg}_{j}" for leg in LEGS for j in ("haa", "hfe", "kfe"))

COLUMNS = (
    "t",
    "x",
    "y",
    "z",
    "q1_true",
    "dq1_true",
    "q1_est",
    "dq1_est",
    "ddq1_est",
    "pitch_front",
    "roll",
    "yaw",
    "q2",
    "q3",
    "q4",
    "dq2",
    "dq3",
    "dq4",
    "tau2",
    "tau3",
    "tau4",
    "spine_x",
    "spine_z",
    "spine_theta",
    "contact_HL",
    "contact_HR",
    "contact_FL",
    "contact_FR",
    "stance_hind",
    "stance_front",
    "leg_power_w",
    "spine_power_w",
    "leg_tau_max",
    # appended for the stiffness study: every joint's applied torque and rate, the gait clock
    *(f"tau_{j}" for j in LEG_JOINTS),
    *(f"dq_{j}" for j in LEG_JOINTS),
    "gait_phase",  # gait clock, cycles in [0, 1): a stride starts where it wraps
    "gait_frequency_hz",
    "spine_spring_energy_j",  # passive spine: energy stored in the spring
)

# the columns computed from the logged torques and rates after the loop (metrics.table.derived_columns);
# the loops write 0 there
DERIVED = ("leg_power_w", "spine_power_w", "leg_tau_max")
