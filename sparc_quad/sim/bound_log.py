"""The layout of a bound run's log row (timeseries.csv): shared by the step loops (`sparc_quad.bound`) that
write it and the metrics (`sparc_quad.metrics`) that read it, so neither imports the other."""

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


def _unit(column: str) -> str:
    if column == "t":
        return "s"
    if column in ("x", "y", "z", "spine_x", "spine_z"):
        return "m"
    if column.startswith(("dq", "dq1")) and not column.startswith("ddq"):
        return "rad/s"
    if column.startswith("ddq"):
        return "rad/s^2"
    if column.startswith(("q", "pitch", "roll", "yaw", "spine_theta")):
        return "rad"
    if column.startswith(("tau", "leg_tau")):
        return "N*m"
    if column.endswith("_w"):
        return "W"
    if column.endswith("_j"):
        return "J"
    if column.endswith("_hz"):
        return "Hz"
    if column == "gait_phase":
        return "cycles"
    return "1"  # contact and stance flags


UNITS = {c: _unit(c) for c in COLUMNS}  # SI unit of each column ("1": a flag or count)
HEADER = ",".join(f"{c} [{UNITS[c]}]" for c in COLUMNS)  # timeseries.csv's header: name [unit]


def column_name(header_field: str) -> str:
    """The column name of one field of timeseries.csv's header ("q2 [rad]" -> "q2")."""
    return header_field.split(" [", 1)[0].strip()
