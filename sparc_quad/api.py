"""The Python entry points, the same runs the command line makes.

    from sparc_quad import Scenario, run_bound, write_outputs
    result = run_bound(Scenario(speed=0.9, kx=800, dx=10, duration=5))
    print(result.metrics["speed_m_s"])
    write_outputs(result, Path("out/mine"))   # scenario.json, metrics.json, timeseries.csv, plots

`run_study` and `run_gap` run a study spec and the sim-vs-measured workflow as `sparc-quad study run` and
`sparc-quad gap run` do. Each imports the simulator only when called.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any

from sparc_quad.scenario import Scenario, bound_config, spine_of, write_scenario


def run_bound(scenario: Scenario, *, backend: str = "auto", realtime: bool = False, spine=None,
              video: bool = False, stop: Callable[[], bool] | None = None):
    """Simulate `scenario`; a `bound.run.BoundResult` whose `scenario` is the one it ran. `backend`
    (auto | numba | python) changes how fast, not what; `spine` (a `SimSpine`) replaces the scenario's
    spine path (`bound --lcm` passes the node over LCM)."""
    from sparc_quad.bound import run as bound_run

    cfg = replace(bound_config(scenario), backend=backend, realtime=realtime)
    spine = spine if spine is not None else spine_of(scenario, cfg)
    result = bound_run.run_bound(cfg, spine=spine, video=video, stop=stop)
    result.scenario = scenario
    return result


def metric_units(metrics: dict[str, Any]) -> dict[str, str]:
    """The unit of every metric in `metrics` that the metrics table or the run facts define."""
    from sparc_quad.bound.run import FACT_UNITS
    from sparc_quad.metrics import TABLE

    units = {**FACT_UNITS, **{name: m.unit for name, m in TABLE.items()}}
    return {name: units[name] for name in metrics if name in units}


def write_outputs(result, out: Path, plots: bool = True) -> list[Path]:
    """scenario.json (when the result came from a scenario), metrics.json, timeseries.csv (units in its
    header), node_states.npz and, with `plots`, the PNG plots."""
    from sparc_quad.bound import run as bound_run

    out = Path(out)
    paths = bound_run.write_outputs(result, out, plots=plots)
    if getattr(result, "scenario", None) is not None:
        paths.insert(0, write_scenario(out, result.scenario, metric_units=metric_units(result.metrics)))
    return paths


def run_study(spec: Path, out: Path, *, workers: int | None = None, scheduler: str | None = None,
              report: bool = False):
    """Run a study spec into `out` (records, trials.csv, summary.json; `report` adds the report) as
    `sparc-quad study run` does; the run's summary."""
    from sparc_quad.study.runner import run_study as _run
    from sparc_quad.study.spec import load_spec

    summary = _run(load_spec(Path(spec)), Path(out), workers=workers, scheduler=scheduler, progress=False)
    if report:
        from sparc_quad.study.report import write_report

        write_report(Path(out))
    return summary


def run_gap(trials: Sequence[Path], out: Path, **options: Any):
    """The sim-vs-measured gap workflow over measured trials (CSV files or an lcm-logger log), as
    `sparc-quad gap run` does; its result (verdict, named effects, fitted plant)."""
    from sparc_quad.gap.workflow import run

    return run([Path(t) for t in trials], Path(out), **options)
