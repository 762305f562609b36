"""The bound metrics, each defined once (name, unit, plot label, definition, function of the logged series).

`sparc-quad bound`, the stiffness study, its report and its claims all read `TABLE`; `measure` computes
every metric of a run from its time series (`sparc_quad.sim.bound_log.COLUMNS`) and a `Context` of the
constants it needs (mass, g, torque limits, winding losses: from the run's params, never typed again here).
"""

from sparc_quad.metrics.table import (
    COTS,
    ELEC_SENSITIVITY,
    GROUPS,
    TABLE,
    Context,
    Metric,
    Series,
    cost_of_transport,
    label,
    measure,
    merge_disjoint,
    saturated,
    stride_starts,
    touchdowns,
)

__all__ = ["COTS", "ELEC_SENSITIVITY", "GROUPS", "TABLE", "Context", "Metric", "Series", "cost_of_transport",
           "label", "measure", "merge_disjoint", "saturated", "stride_starts", "touchdowns"]
