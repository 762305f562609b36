"""Run one bound of the spined quadruped and measure it.

`run_bound(BoundConfig(...))` is a pure function of its configuration (its own physics world, its own
seeded generator, no files written): the stiffness study fans these out. `write_outputs` turns a result
into metrics.json, a CSV time series and PNG plots.
"""

from __future__ import annotations

import collections
import struct
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path

import numpy as np

from sparc_quad.bound.backend import load_compiled, resolve_backend
from sparc_quad.gaits.authors_raibert import AuthorsRaibertController, AuthorsRaibertParams
from sparc_quad.gaits.base import Gait
from sparc_quad.gaits.bound import BoundController, BoundParams
from sparc_quad.gaits.sine_bound import SineBoundController, SineBoundParams
from sparc_quad.jsonfmt import json_text
from sparc_quad.metrics import table as metrics_table
from sparc_quad.sim.bound_log import COLUMNS, DERIVED, HEADER, LEGS
from sparc_quad.sim.fall import FALL_REASONS, fall_code
from sparc_quad.sim.hosts import leg_winding
from sparc_quad.sim.quadruped_world import HELD_STATE, QuadWorld, WorldConfig, make_world
from sparc_quad.sim.sim_spine import DirectSpine, SimSpine
from sparc_quad.sim.spine_drive import SpineGains, SpineSchedule
from spine_module import params as P


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


def fall_reason(world: QuadWorld, pitch_front: float) -> str | None:
    return _fall_reason(world.body_contact, world.q1, pitch_front, world.roll, world.cfg.slope_rad)


def _fall_reason(body_contact: bool, q1: float, pitch_front: float, roll: float, slope: float) -> str | None:
    return FALL_REASONS[fall_code(body_contact, q1, pitch_front, roll, slope)]


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


PROFILE_PHASES = ("read", "spine", "gait", "log", "physics", "other")

# A held step's log row: the world packs HELD_STATE; the loop packs HELD_AUX (after the index of the row whose
# torques and stance the step holds); HELD_KEPT is copied from that row; the power and peak columns are
# derived after the loop, as for every row.
HELD_AUX = ("t", "q1_true", "dq1_true", "roll", "yaw", "q1_est", "dq1_est", "ddq1_est", "pitch_front",
            "spine_x", "spine_z", "spine_theta", "gait_phase", "gait_frequency_hz", "spine_spring_energy_j")
HELD_KEPT = ("tau2", "tau3", "tau4", "stance_hind", "stance_front",
             *(c for c in COLUMNS if c.startswith("tau_")))
if sorted((*HELD_STATE, *HELD_AUX, *HELD_KEPT, *DERIVED)) != sorted(COLUMNS):
    raise RuntimeError("a held step's row must cover every log column once (bound_run.HELD_*)")
_COL = {c: k for k, c in enumerate(COLUMNS)}
_HELD_STATE_COLS = [_COL[c] for c in HELD_STATE]
_HELD_AUX_COLS = [_COL[c] for c in HELD_AUX]
_HELD_KEPT_COLS = [_COL[c] for c in HELD_KEPT]


def fill_held_rows(series: np.ndarray, world: QuadWorld, aux: np.ndarray) -> None:
    """Complete the held steps' rows of `series` in place: `aux[:, 0]` is the index of the row each holds
    (-1: a row the loop packed in full), `aux[:, 1:]` its HELD_AUX values, `world.held_rows` its
    HELD_STATE values."""
    rows = np.flatnonzero(aux[:, 0] >= 0.0)
    if not len(rows):
        return
    src = aux[rows, 0].astype(np.intp)
    series[np.ix_(rows, _HELD_STATE_COLS)] = world.held_rows(rows)
    series[np.ix_(rows, _HELD_AUX_COLS)] = aux[rows, 1:]
    series[np.ix_(rows, _HELD_KEPT_COLS)] = series[np.ix_(src, _HELD_KEPT_COLS)]


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
    from the world's renderer at VIDEO_FPS. `profile`, when given, accumulates wall seconds
    (time.perf_counter) per phase of each step: read (world.estimate), spine, gait, log (torques sent,
    leg states read, log row), physics (world.step: stepSimulation + state refresh), other (fall
    check); when None the loop takes no
    timestamps. `stop()`, when given, is asked before each step computed in full (held steps run between
    those, at most the gait's control period); True raises KeyboardInterrupt there (the
    CLI's Ctrl-C: the exception is raised in this loop, never inside an extension's call). `held_steps`
    False runs every step through the full path (the reference the held steps are tested against).
    `compiled_loop` False keeps a compiled run's steps in the Python loop (the reference of
    `bound.compiled_loop`, which runs them otherwise where it can: `CompiledLoop.why_not`)."""
    frames: list = []
    if video:
        on_frame, frame_every_s = (lambda w: frames.append(w.render())), 1.0 / VIDEO_FPS
    variant = variant_of(cfg)
    world_cfg = replace(cfg.world, lock_spine=True) if variant == "rigid" else cfg.world
    backend = resolve_backend(cfg.backend, cfg.duration_s)
    if backend == "numba":
        load_compiled()
    world = make_world(world_cfg)
    spine = spine if spine is not None else direct_spine(cfg)
    gait = make_gait(world, cfg.gait, backend)
    pose = gait.start_pose()
    if pose is not None:  # a gait that starts on its trajectory
        world.set_start(*pose)
    observe_spine = gait.observe_spine
    dt = cfg.world.dt_s
    n = round(cfg.duration_s / dt)
    log = np.zeros((n, len(COLUMNS)))
    frame_every = round(frame_every_s / dt) if frame_every_s > 0 else 0
    fell, fall_t, first_reason = False, None, None
    legs_order = LEGS
    if tuple(legs_order) != ("HL", "HR", "FL", "FR"):
        raise ValueError(f"the log row lists the legs HL, HR, FL, FR, got {legs_order}")
    leg_dq = world.leg_rates  # HL, HR, FL, FR x (HAA, HFE, KFE)
    gait_phase, gait_frequency = gait.phase_fraction, gait.frequency
    latency = max(0, int(cfg.actuator_latency_steps))
    pipe: collections.deque = collections.deque()
    zero_legs = {k: (0.0, 0.0, 0.0) for k in legs_order}
    prof = profile is not None
    if prof:
        for key in PROFILE_PHASES:
            profile.setdefault(key, 0.0)
    clock = time.perf_counter
    c0 = c1 = 0.0
    # the per-step calls bound once (the loop's cost is Python's)
    estimate, spine_begin, spine_finish, gait_step = world.estimate, spine.begin, spine.finish, gait.step
    set_torques, world_step, realtime = world.set_torques, world.step, cfg.realtime
    flags = gait.stance_flags
    ndarray = np.ndarray
    # a log row is packed as doubles straight into its place in `log` (PyFloat_AsDouble per value, the same
    # doubles numpy's row assignment makes, without the temporary array)
    row = struct.Struct(f"{len(COLUMNS)}d")
    pack_row, row_bytes = row.pack_into, row.size
    # Held steps: after a step computed in full, the engine runs it and the steps up to the gait's next
    # call (the authors' clock) back to back with the controls as they are (`world.step_chunk`: MuJoCo
    # keeps the raw states); the estimator, the spine and the gait's clock then catch up on those states
    # in order and the loop packs the rest of their rows (`aux`). A spine torque that changed in a chunk
    # rewinds the world to that step, which then runs in full. The held rows are completed after the loop
    # (`fill_held_rows`). Same numbers as the full path at every step (tests/sparc_quad/sim/
    # test_held_steps.py), which runs whenever profiling, frames, real time or latency need it, and on
    # worlds that cannot rewind (pybullet).
    # (a spine that holds its torque between its own clock's calls: the direct spine with a clocked drive;
    # a node spine's torque moves every step and would rewind every chunk)
    holds = (held_steps and world.can_rewind and gait.clock is not None and spine.clocked
             and not latency and not prof and not frame_every and not realtime)
    idle_ticks = gait.clock.idle_ticks if holds else None
    if holds:
        world.start_held(n + 1)  # row i: the state before step i
    aux = np.full((n if holds else 0, 1 + len(HELD_AUX)), -1.0)
    pack_aux = struct.Struct(f"{1 + len(HELD_AUX)}d").pack_into
    aux_bytes = 8 * (1 + len(HELD_AUX))
    est_update, step_chunk = world.estimator.update, world.step_chunk
    slope = world.cfg.slope_rad
    pending = None  # a step whose estimator, spine and gait ran in a chunk's catch-up: its full path
    # the compiled loop: every step in full, its control half one compiled call (the same doubles as the
    # loop below: tests/sparc_quad/sim/test_compiled_loop.py)
    fast = None
    if compiled_loop and backend == "numba" and not (holds or latency or prof or frame_every or realtime):
        from sparc_quad.bound.compiled_loop import CompiledLoop  # numba runs only (a short run's import cost)

        if CompiledLoop.why_not(world, spine, gait) is None:
            fast = CompiledLoop(world, spine, gait)
    t0 = time.perf_counter()
    i = 0
    try:
        if fast is not None:  # the control half of every step in one compiled call (sim.compiled_loop)
            i, fell, fall_t, first_reason = fast.run(log, n, stop, cfg.stop_on_fall)
        else:
            while i < n:
                if stop is not None and stop():
                    raise KeyboardInterrupt
                if pending is not None:
                    t, est, q_sp, dq_sp, leg_tau, tau_s = pending
                    pending = None
                else:
                    if prof:
                        c0 = clock()
                    t = world.t
                    est = estimate()
                    if prof:
                        c1 = clock()
                        profile["read"] += c1 - c0
                    q_sp, dq_sp = world.q_spine, world.dq_spine
                    spine_begin(est, q_sp, dq_sp, t)  # a node elsewhere works while the gait runs
                    if prof:
                        c0 = clock()
                        profile["spine"] += c0 - c1
                    leg_tau = gait_step(t)
                    if prof:
                        c1 = clock()
                        profile["gait"] += c1 - c0
                    tau_s = spine_finish()  # the gait does not read the spine: the order changes no number
                    if prof:
                        c0 = c1
                        c1 = clock()
                        profile["spine"] += c1 - c0
                if latency:  # what the actuators apply now was commanded `latency` steps ago
                    pipe.append((tuple(tau_s), {k: tuple(v) for k, v in leg_tau.items()}))
                    tau_s, leg_tau = pipe.popleft() if len(pipe) > latency else ((0.0, 0.0, 0.0), zero_legs)
                tau_s = tau_s.tolist() if type(tau_s) is ndarray else tau_s  # plain floats: cheaper below
                set_torques(tau_s, leg_tau)
                task = spine.task_pose  # as of this step's begin: read once for the gait and the log
                task = task.tolist() if type(task) is ndarray else task
                observe_spine(t, float(task[0]))
                # log the state the torques were computed from: one row, one pack; the power and peak
                # columns are filled from the logged torques and rates after the loop
                # (metrics.derived_columns)
                q1 = world.q1
                cf = world.contact_force
                pack_row(log, i * row_bytes, t, *world.base_pos, q1, world.dq1, est.q1, est.dq1, est.ddq1,
                         q1 + sum(q_sp), world.roll, world.yaw, *q_sp, *dq_sp, *tau_s,
                         *task, cf["HL"] > 0.0, cf["HR"] > 0.0, cf["FL"] > 0.0, cf["FR"] > 0.0,
                         flags["hind"], flags["front"], 0.0, 0.0, 0.0,
                         *leg_tau["HL"], *leg_tau["HR"], *leg_tau["FL"], *leg_tau["FR"], *leg_dq(),
                         gait_phase(), gait_frequency(), spine.energy_j)
                if frame_every and i % frame_every == 0 and on_frame is not None:
                    on_frame(world)
                if prof:
                    c0 = clock()
                    profile["log"] += c0 - c1
                if holds:
                    # this step and the held ones up to the gait's next call, then their catch-up
                    k = min(1 + idle_ticks(), n - i)
                    s0 = s = i
                    for t1, q1, dq1, roll, yaw, q_sp1, dq_sp1, body, twist in step_chunk(k, i):
                        # the state after step s: its fall check, then (inside the chunk) step s + 1's
                        # catch-up
                        pf1 = q1 + sum(q_sp1)
                        if not fell:
                            reason = _fall_reason(body, q1, pf1, roll, slope)
                            if reason is not None:
                                fell, fall_t, first_reason = True, t1, reason
                                if cfg.stop_on_fall:
                                    break
                        s += 1
                        if s == s0 + k:
                            break
                        est = est_update(q1, dq1, twist)
                        spine_begin(est, q_sp1, dq_sp1, t1)
                        leg_tau = gait_step(t1)
                        tau_s1 = spine_finish()
                        if not (type(tau_s1) is list and tau_s1 == tau_s):  # the spine's torque changed
                            world.rewind(s - s0)
                            pending = (t1, est, q_sp1, dq_sp1, leg_tau, tau_s1)
                            break
                        task = spine.task_pose
                        task = task.tolist() if type(task) is ndarray else task
                        pack_aux(aux, s * aux_bytes, s0, t1, q1, dq1, roll, yaw, est.q1, est.dq1, est.ddq1,
                                 pf1, *task, gait_phase(), gait_frequency(), spine.energy_j)
                    if fell and cfg.stop_on_fall:
                        i = s + 1
                        break
                    i = s
                    continue
                world_step()
                if prof:
                    c1 = clock()
                    profile["physics"] += c1 - c0
                if realtime:
                    lag = t0 + world.t - time.perf_counter()
                    if lag > 0:
                        time.sleep(lag)
                i += 1
                if not fell:  # the first fall's time and reason are kept (stop_on_fall=False runs on)
                    reason = fall_reason(world, world.q1 + sum(world.q_spine))
                    if reason is not None:
                        fell, fall_t, first_reason = True, world.t, reason
                        if cfg.stop_on_fall:
                            break
                if prof:
                    profile["other"] += clock() - c1
    finally:
        wall = time.perf_counter() - t0
        physics_wall = world.physics_wall_s
        mass = world.total_mass
        limits = world.meta
        world.close()
        spine.close()
    series = log[:i]
    if holds:
        fill_held_rows(series, world, aux[:i])
    metrics_table.derived_columns(series)
    # metrics end at the first fall: what a fallen robot does afterwards (stop_on_fall=False) is no gait
    measured = series[: max(1, round(fall_t / dt))] if fell and fall_t is not None else series
    actuated = spine.actuated
    t_start = window_start_s(cfg)
    ctx = metrics_table.Context(
        dt_s=dt, mass_kg=mass, gravity_m_s2=cfg.world.gravity_m_s2, slope_rad=cfg.world.slope_rad,
        leg_torque_limit_nm=float(limits["leg_torque_limit_nm"]),
        spine_torque_limit_nm=float(limits["spine_torque_limit_nm"]), spine_actuated=actuated,
        leg_winding=leg_winding(cfg.world.host))
    facts = run_facts(series, cfg, mass, fell, fall_t, first_reason, t_start, actuated)
    metrics = metrics_table.merge_disjoint(facts, metrics_table.measure(measured, ctx, t_start))
    metrics["wall_time_s"] = wall
    metrics["physics_wall_time_s"] = physics_wall
    metrics["held_steps"] = int((aux[:i, 0] >= 0.0).sum()) if holds else 0  # steps run inside a chunk
    # which loop ran the steps: "compiled" (sim.compiled_loop), "held" (the Python loop with held chunks) or
    # "python" (every step in the Python loop)
    metrics["loop"] = "compiled" if fast is not None else "held" if holds else "python"
    metrics["spine_path"] = spine.name
    metrics["spine_driver"] = spine.driver
    metrics["spine_backend"] = spine.backend
    metrics["gait_backend"] = gait.backend
    node_states = spine.node_states()
    return BoundResult(cfg, metrics, series, wall, frames, node_states)


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
