"""Run one bound of the spined quadruped and measure it.

`run_bound(BoundConfig(...))` is a pure function of its configuration (its own physics world, its own
seeded generator, no files written): the stiffness study fans these out. `write_outputs` turns a result
into metrics.json, a CSV time series and PNG plots.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path

import numpy as np

from sparc_quad.bound.backend import load_compiled, resolve_backend
from sparc_quad.bound.held_loop import fill_held_rows
from sparc_quad.bound.loops import choose_loop
from sparc_quad.bound.python_loop import PROFILE_PHASES, fall_reason
from sparc_quad.bound.stepping import Ended, Steps
from sparc_quad.gaits.authors_raibert import AuthorsRaibertController, AuthorsRaibertParams
from sparc_quad.gaits.base import Gait
from sparc_quad.gaits.bound import BoundController, BoundParams
from sparc_quad.gaits.sine_bound import SineBoundController, SineBoundParams
from sparc_quad.jsonfmt import json_text
from sparc_quad.metrics import table as metrics_table
from sparc_quad.sim.bound_log import COLUMNS, HEADER
from sparc_quad.sim.hosts import leg_winding
from sparc_quad.sim.quadruped_world import QuadWorld, WorldConfig, make_world
from sparc_quad.sim.sim_spine import DirectSpine, SimSpine
from sparc_quad.sim.spine_drive import SpineGains, SpineSchedule
from spine_module import params as P

# names kept here for their users: the Python loop's phases and fall test, the held rows' completion
__all__ = ["PROFILE_PHASES", "fall_reason", "fill_held_rows"]


@dataclass(frozen=True)
class BoundConfig:
    duration_s: float = 10.0
    gait: BoundParams | SineBoundParams | AuthorsRaibertParams = field(default_factory=BoundParams)
    world: WorldConfig = field(default_factory=WorldConfig)
    spine: SpineGains = field(default_factory=SpineGains)
    spine_variant: str = "impedance"  # impedance | passive | rigid | rigid-impedance (spine_drive)
    spine_schedule: SpineSchedule | None = None  # the authors' gain switch (gait A)
    spine_rate_hz: float | None = None  # motor-rendered spine controller rate (None: every sim step)
    spine_timing: str = "hold"  # hold (every 1/rate from step 0) | authors (their loop's clock, spine_drive)
    spine_params: P.SpineParams | None = None  # the impedance controller's model (None: the SPARC module)
    spine_torso_accel: bool = True  # feed the estimator's q̈1 to the spine law (False: 0, as the authors')
    actuator_latency_steps: int = 0  # every joint torque is applied this many 1 ms steps late
    friction_compensation: bool = False
    stop_on_fall: bool = True
    realtime: bool = False  # pace the loop to the wall clock (the robot's real-time mode)
    settle_s: float = 2.0  # metrics skip the start-up (stand, speed ramp) plus this
    # per-step code: numba (compiled spine step and bound controller) | python (the reference paths) |
    # auto (numba for runs >= backend.NUMBA_PAYBACK_SIM_S, where it pays for loading the kernels)
    backend: str = "auto"


@dataclass
class BoundResult:
    config: BoundConfig
    metrics: dict
    series: np.ndarray  # (steps, len(COLUMNS))
    wall_s: float
    frames: list = field(default_factory=list)
    node_states: dict | None = None  # the spine node's states (node and LCM paths)
    scenario: object | None = None  # the `sparc_quad.scenario.Scenario` it ran, when it came from one

    def column(self, name: str) -> np.ndarray:
        return self.series[:, COLUMNS.index(name)]


def direct_spine(cfg: BoundConfig) -> DirectSpine:
    """The run's spine called in this process (`SimSpine`'s fast configuration; see `sim.sim_spine`)."""
    return DirectSpine(cfg.spine, variant=variant_of(cfg), friction=cfg.friction_compensation,
                       schedule=cfg.spine_schedule, rate_hz=cfg.spine_rate_hz, dt_s=cfg.world.dt_s,
                       backend=_SPINE_BACKEND[resolve_backend(cfg.backend, cfg.duration_s)],
                       timing=cfg.spine_timing, spine=cfg.spine_params, torso_accel=cfg.spine_torso_accel)


VIDEO_FPS = 25


def variant_of(cfg: BoundConfig) -> str:
    return cfg.spine_variant


_SPINE_BACKEND = {"numba": "numba", "python": "pinocchio"}


def make_gait(world: QuadWorld, params: BoundParams | SineBoundParams | AuthorsRaibertParams,
              backend: str = "python") -> Gait:
    """The leg controller; `backend` "numba": gait B's whole step compiled, gait A's joint PD at its calls
    (gait C has only its Python path)."""
    if isinstance(params, SineBoundParams):
        return SineBoundController(world, params, backend)
    if isinstance(params, AuthorsRaibertParams):
        return AuthorsRaibertController(world, params)
    if backend == "numba":
        from sparc_quad.gaits.bound_fast import CompiledBoundController

        return CompiledBoundController(world, params)
    return BoundController(world, params)


def run_bound(
    cfg: BoundConfig,
    spine: SimSpine | None = None,
    on_frame: Callable | None = None,
    frame_every_s: float = 0.0,
    video: bool = False,
    profile: dict[str, float] | None = None,
    stop: Callable[[], bool] | None = None,
    held_steps: bool = True,
    compiled_loop: bool = True,
) -> BoundResult:
    """Simulate `cfg.duration_s` of bounding. `spine` (a `SimSpine`) defaults to the run's spine called in
    process (`direct_spine(cfg)`). `on_frame(world)` is called every `frame_every_s`; `video` collects frames
    from the world's renderer at VIDEO_FPS. `profile`, when given, accumulates wall seconds per phase of each
    step (`python_loop.PROFILE_PHASES`); when None the loop takes no timestamps. `stop()`, when given, is
    asked before each step computed in full; True raises KeyboardInterrupt there (the CLI's Ctrl-C: raised in
    the loop, never inside an extension's call). One loop runs the steps (`loops.choose_loop`: held chunks,
    the compiled loop or the Python loop; metrics' "loop" names it); `held_steps` or `compiled_loop` False
    leaves that loop out (the Python loop is the reference both are tested against)."""
    frames: list = []
    if video:
        on_frame, frame_every_s = (lambda w: frames.append(w.render())), 1.0 / VIDEO_FPS
    backend = resolve_backend(cfg.backend, cfg.duration_s)
    world, spine, gait = _build(cfg, spine, backend)
    dt = cfg.world.dt_s
    s = Steps(world, spine, gait, np.zeros((round(cfg.duration_s / dt), len(COLUMNS))), stop=stop,
              stop_on_fall=cfg.stop_on_fall, latency=max(0, int(cfg.actuator_latency_steps)),
              realtime=cfg.realtime, profile=profile, on_frame=on_frame,
              frame_every=round(frame_every_s / dt) if frame_every_s > 0 else 0)
    loop = choose_loop(s, backend, held_steps=held_steps, compiled_loop=compiled_loop)
    t0 = time.perf_counter()
    try:
        end = loop.run(s)
    finally:
        wall = time.perf_counter() - t0
        physics_wall, mass, limits = world.physics_wall_s, world.total_mass, world.meta
        world.close()
        spine.close()
    series = s.log[:end.steps]
    metrics = _measure(cfg, series, end, mass, limits, spine.actuated)
    metrics.update(wall_time_s=wall, physics_wall_time_s=physics_wall,
                   held_steps=end.held_steps,  # steps run inside a held chunk
                   loop=loop.name, spine_path=spine.name, spine_driver=spine.driver,
                   spine_backend=spine.backend, gait_backend=gait.backend)
    return BoundResult(cfg, metrics, series, wall, frames, spine.node_states())


def _build(cfg: BoundConfig, spine: SimSpine | None, backend: str) -> tuple[QuadWorld, SimSpine, Gait]:
    """The run's world (its spine locked when rigid), spine and leg controller, the robot on the gait's
    start pose."""
    if backend == "numba":
        load_compiled()
    world = make_world(replace(cfg.world, lock_spine=True) if variant_of(cfg) == "rigid" else cfg.world)
    spine = spine if spine is not None else direct_spine(cfg)
    gait = make_gait(world, cfg.gait, backend)
    pose = gait.start_pose()
    if pose is not None:  # a gait that starts on its trajectory
        world.set_start(*pose)
    return world, spine, gait


def _measure(cfg: BoundConfig, series: np.ndarray, end: Ended, mass: float, limits: dict,
             actuated: bool) -> dict:
    """The run's facts and metrics from its log (whose derived columns are filled here)."""
    metrics_table.derived_columns(series)
    # metrics end at the first fall: what a fallen robot does afterwards (stop_on_fall=False) is no gait
    fell, fall_t = end.fell, end.fall_t
    measured = series[: max(1, round(fall_t / cfg.world.dt_s))] if fell and fall_t is not None else series
    t_start = window_start_s(cfg)
    ctx = metrics_table.Context(
        dt_s=cfg.world.dt_s, mass_kg=mass, gravity_m_s2=cfg.world.gravity_m_s2,
        slope_rad=cfg.world.slope_rad, leg_torque_limit_nm=float(limits["leg_torque_limit_nm"]),
        spine_torque_limit_nm=float(limits["spine_torque_limit_nm"]), spine_actuated=actuated,
        leg_winding=leg_winding(cfg.world.host))
    facts = run_facts(series, cfg, mass, fell, fall_t, end.reason, t_start, actuated)
    return metrics_table.merge_disjoint(facts, metrics_table.measure(measured, ctx, t_start))


def startup_s(cfg: BoundConfig) -> float:
    """When the gait has reached its running state: start, ramps and (gait A) the spine switch."""
    gp = cfg.gait
    if isinstance(gp, AuthorsRaibertParams):
        return gp.running_from_s
    if isinstance(gp, SineBoundParams):
        t = gp.running_from_s
        if cfg.spine_schedule is not None:
            t = max(t, cfg.spine_schedule.switch_s)
        return t
    ramp = abs(gp.speed_m_s) / gp.accel_m_s2 if gp.accel_m_s2 > 0 else 0.0
    return gp.start_s + ramp


def window_start_s(cfg: BoundConfig) -> float:
    """Where the metrics' steady window starts: start-up plus `settle_s`, at most half the run."""
    return min(startup_s(cfg) + cfg.settle_s, 0.5 * cfg.duration_s)


def run_facts(s: np.ndarray, cfg: BoundConfig, mass: float, fell: bool, fall_t: float | None,
              reason: str | None, t_start: float, actuated: bool) -> dict:
    """What the run was and how it ended (not metrics: `sparc_quad.metrics.TABLE` holds those)."""
    return {
        "fell": bool(fell),
        "fall_time_s": fall_t,
        "fall_reason": reason,
        "simulated_s": float(s[-1, 0] + cfg.world.dt_s) if len(s) else 0.0,
        "window_s": [float(t_start), float(s[-1, 0]) if len(s) else 0.0],
        "mass_kg": mass,
        "slope_rad": cfg.world.slope_rad,
        "target_speed_m_s": cfg.gait.speed_m_s,
        "rigid_spine": variant_of(cfg) == "rigid",
        "spine_variant": variant_of(cfg),
        "spine_actuated": actuated,
        "spine_k": list(cfg.spine.k),
        "spine_d": list(cfg.spine.d),
    }


# units of the run facts (`run_facts`) and loop figures in metrics.json; the metrics' own are in
# sparc_quad.metrics.TABLE
FACT_UNITS = {"fall_time_s": "s", "simulated_s": "s", "window_s": "s", "mass_kg": "kg", "slope_rad": "rad",
              "target_speed_m_s": "m/s", "spine_k": "N/m, N/m, N*m/rad", "spine_d": "N*s/m, N*s/m, N*m*s/rad",
              "wall_time_s": "s (wall)", "physics_wall_time_s": "s (wall)", "held_steps": "steps"}


def config_dict(cfg: BoundConfig) -> dict:
    return asdict(cfg)


def write_outputs(result: BoundResult, out: Path, plots: bool = True) -> list[Path]:
    """metrics.json, timeseries.csv, node_states.npz (node paths) and, with `plots`, the PNG plots (gait
    diagram, pitches, spine states, torques) and bound.gif. Without plots matplotlib is never imported
    (about 1 s of CPU per process: a sweep of short runs should not pay it)."""
    out.mkdir(parents=True, exist_ok=True)
    paths = []
    metrics = dict(result.metrics)
    metrics["config"] = config_dict(result.config)
    p = out / "metrics.json"
    p.write_text(json_text(metrics, indent=2) + "\n")  # undefined metrics (NaN) as null
    paths.append(p)
    p = out / "timeseries.csv"
    np.savetxt(p, result.series, delimiter=",", header=HEADER, comments="", fmt="%.9g")
    paths.append(p)
    if result.node_states:
        p = out / "node_states.npz"
        np.savez(p, **result.node_states)
        paths.append(p)
    if plots:
        paths += write_plots(result, out)
    return paths


def write_plots(result: BoundResult, out: Path) -> list[Path]:
    """The PNG plots and (frames collected) bound.gif into `out`."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    paths = []
    t = result.column("t")
    cfg = result.config
    run = (f"{cfg.world.host} in {cfg.world.engine}, spine {variant_of(cfg)}, k_x {cfg.spine.k[0]:g} N/m, "
           f"d_x {cfg.spine.d[0]:g} N*s/m")
    t_end = t[-1] if len(t) else 0.0
    t_from = max(0.0, t_end - 2.0)
    fig, ax = plt.subplots(figsize=(10, 2.6))
    for k, leg in enumerate(("HL", "HR", "FL", "FR")):
        c = result.column(f"contact_{leg}") > 0.5
        edges = np.flatnonzero(np.diff(np.r_[0, c.astype(int), 0]))
        spans = [(t[a], (t[b - 1] - t[a]) + 1e-3) for a, b in zip(edges[::2], edges[1::2], strict=True)]
        ax.broken_barh(spans, (k - 0.4, 0.8), color="k")
    ax.set_yticks(range(4), ["HL", "HR", "FL", "FR"])
    ax.set_xlabel("t (s)")
    ax.set_title(f"gait diagram (foot contact), the last {t_end - t_from:.1f} s of the run "
                 f"({t_from:.1f}-{t_end:.1f} s); {run}", fontsize=9)
    ax.set_xlim(t_from, t_end)
    fig.tight_layout()
    paths.append(_save(fig, out / "gait_diagram.png"))
    paths.append(_series_plot(out / "body_pitch.png", t, [
        ("hind body pitch q1 (true)", result.column("q1_true"), {}),
        ("q1 (estimator)", result.column("q1_est"), {"lw": 0.6}),
        ("front body pitch", result.column("pitch_front"), {}),
    ], "rad (+ nose down)", f"body pitch, whole run (0-{t_end:.1f} s); {run}"))
    fig, axes = plt.subplots(3, 1, figsize=(10, 6), sharex=True)
    for ax, name, unit in zip(axes, ("x", "z", "theta"), ("m", "m", "rad"), strict=True):
        ax.plot(t, result.column(f"spine_{name}"))
        ax.set_ylabel(f"spine {name} ({unit})")
    axes[-1].set_xlabel("t (s)")
    axes[0].set_title(f"spine task pose (front body in the hind-body frame), whole run; {run}", fontsize=9)
    fig.tight_layout()
    paths.append(_save(fig, out / "spine_task_space.png"))
    paths.append(_series_plot(out / "torques.png", t, [
        *((f"q{j}", result.column(f"tau{j}"), {"lw": 0.8}) for j in (2, 3, 4)),
        ("max |leg torque|", result.column("leg_tau_max"), {"lw": 0.5, "color": "grey"}),
    ], "N*m", f"spine joint torques and the largest leg torque, whole run; {run}"))
    if result.frames:
        from matplotlib import animation

        fig = plt.figure(figsize=(result.frames[0].shape[1] / 100, result.frames[0].shape[0] / 100), dpi=100)
        ax = fig.add_axes((0, 0, 1, 1))
        ax.axis("off")
        img = ax.imshow(result.frames[0])

        def update(i):
            img.set_data(result.frames[i])
            return (img,)

        anim = animation.FuncAnimation(fig, update, frames=len(result.frames), blit=True)
        p = out / "bound.gif"
        anim.save(p, writer=animation.PillowWriter(fps=VIDEO_FPS))
        plt.close(fig)
        paths.append(p)
    return paths


def _series_plot(path: Path, t: np.ndarray, series: list[tuple[str, np.ndarray, dict]], ylabel: str,
                 title: str) -> Path:
    """One axes of named series (label, values, line style) against t, the legend off the data (body
    pitch, torques): the figure, axis labels and legend spelled once, each plot only its series and title."""
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(10, 3.5))
    for label, y, style in series:
        ax.plot(t, y, label=label, **style)
    ax.set_xlabel("t (s)")
    ax.set_ylabel(ylabel)
    ax.set_title(title, fontsize=9)
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8)
    fig.tight_layout()
    return _save(fig, path)


def _save(fig, path: Path) -> Path:
    fig.savefig(path, dpi=110)
    import matplotlib.pyplot as plt

    plt.close(fig)
    return path
