"""The project's gait A on the spined dog (run_bound: MuJoCo world, gait, spine_module impedance controller
on the authors' schedule and clock) against the authors' bound re-expressed and run directly in MuJoCo on
the same MJCF (tests/reference/authors_bound.py).

Both start as the authors' main_robot.py starts: the legs posed at the trot's phase offsets (it poses them
before it switches its generator to the bound). The port's estimate gives the spine law the base's
acceleration as their code feeds their law (WorldConfig.base_motion "authors-cvel": a = w x v of the hind
body's MuJoCo `cvel` read one step late as its body twist; their h is a floating-base RNEA at that twist
with zero spatial base acceleration; on the port's states the base term is theirs within 0.0045 N*m RMS).
Then the remaining differences are the spine laws': the project's computed-acceleration law on a planar
model with q1 a hinge vs their 3-D floating-base h, classical vs spatial J̇q̇, damped pseudo-inverse vs
regularised Λ, amplified by the open-loop bound at every touchdown.

Tolerance (hind body x, z, pitch; L = 0.08 m, k_x = 800 N/m, the first 2 s; `MAX_05` over the first 0.5 s,
`RMS_2` over 2 s): 1.5 times the port's error with the authors-cvel estimate when the bounds were set,
rounded up to two digits. That is about what one law detail alone moves the reference against itself, and
ports wrong in one respect (the fixed-origin law, the true body twist, the SPARC module's spine model, the
literal arc, the bound's start offsets) exceed it, so the bounds tell the port from a wrong one. The
figures behind them: notebook/2026-12-07-test-docstring-figures.md.
"""

from __future__ import annotations

import functools
from dataclasses import replace

import numpy as np
import pytest

from tests.paths import ROOT

pytest.importorskip("mujoco")

from sparc_quad.bound.run import run_bound
from sparc_quad.gaits import authors_run
from sparc_quad.sim.control_clock import ControlClock
from tests.reference import authors_bound as ref
from tests.scenarios import authors_config

MJCF = ROOT / "robots" / "spined_dog" / "spined_dog.xml"
MAX_05 = {"x": 0.0037, "z": 0.0029, "pitch": 0.023}
RMS_2 = {"x": 0.0028, "z": 0.0016, "pitch": 0.0051}


def _pair(step_length_m: float, k_x: float, duration_s: float, engine: str = "mujoco"):
    cfg = authors_config(step_length_m, k_x, duration_s, engine=engine)
    ours = run_bound(cfg)
    theirs = ref.run_authors_bound(ref.AuthorsBoundConfig(step_length_m=step_length_m, k_x=k_x,
                                                          duration_s=duration_s),
                                   model=ref.load_model(mjcf_path=MJCF))
    return ours, theirs


def _errors(ours, theirs, t_end: float) -> dict[str, np.ndarray]:
    n = min(len(ours.series), len(theirs.t), round(t_end / 1e-3))
    assert np.allclose(ours.column("t")[:n], theirs.t[:n], atol=1e-9)
    return {"x": ours.column("x")[:n] - theirs.x[:n], "z": ours.column("z")[:n] - theirs.z[:n],
            "pitch": ours.column("q1_true")[:n] - theirs.pitch[:n]}


def _speed(t: np.ndarray, x: np.ndarray, t0: float = 4.0) -> float:
    w = t >= t0
    return float((x[w][-1] - x[w][0]) / (t[w][-1] - t[w][0]))


def test_gait_a_follows_the_authors_run_for_2_s():
    ours, theirs = _pair(0.08, 800.0, 2.0)
    assert ours.config.world.base_motion == "authors-cvel"
    assert not ours.metrics["fell"] and theirs.fall_time_s is None
    e = _errors(ours, theirs, 2.0)
    assert len(e["x"]) == 2000
    for name, err in e.items():
        assert np.abs(err[:500]).max() <= MAX_05[name], (name, np.abs(err[:500]).max())
        assert np.sqrt(np.mean(err**2)) <= RMS_2[name], (name, np.sqrt(np.mean(err**2)))
    # their loop called its controller where the project's clock calls the gait and the spine
    clock = ControlClock(1.0 / authors_run.AUTHORS_CONTROL_HZ, 1e-3)
    assert theirs.control_calls == sum(clock.tick() for _ in range(2000))


@pytest.mark.slow
@pytest.mark.parametrize("k_x", [300.0, 800.0, 1200.0])
def test_both_fall_at_the_authors_step_length(k_x):
    """L = 0.12 m (their default): both fall within 4 s, as the authors' released code does at every k_x
    (fall times: notebook/2026-12-07-test-docstring-figures.md)."""
    ours, theirs = _pair(0.12, k_x, 5.0)
    assert ours.metrics["fell"] and ours.metrics["fall_time_s"] < 4.0
    assert theirs.fall_time_s is not None and theirs.fall_time_s < 4.0


@functools.cache
def _pair_20_s(step_length_m: float, k_x: float):
    return _pair(step_length_m, k_x, 20.0)


@pytest.mark.slow
@pytest.mark.parametrize("step_length_m,k_x", [(0.07, 300.0), (0.08, 800.0)])
def test_both_run_20_s(step_length_m, k_x):
    """Both run 20 s, the reference at the issue's 0.6-1.0 m/s (speed of the hind body from 4 s), where the
    authors' released code runs (speeds: notebook/2026-12-07-test-docstring-figures.md)."""
    ours, theirs = _pair_20_s(step_length_m, k_x)
    assert not ours.metrics["fell"] and theirs.fall_time_s is None
    assert 0.6 <= _speed(theirs.t, theirs.x) <= 1.0


@pytest.mark.slow
@pytest.mark.parametrize("step_length_m,k_x", [(0.07, 300.0), (0.08, 800.0)])
def test_ours_runs_at_the_authors_speed(step_length_m, k_x):
    """Ours at 0.6-1.0 m/s over 20 s, within 0.02 m/s of the reference, with the authors-cvel estimate (the
    true body twist or the fixed origin land slow at L 0.08 m: the frequency adaptation is bistable; speeds:
    notebook/2026-12-07-test-docstring-figures.md)."""
    ours, theirs = _pair_20_s(step_length_m, k_x)
    speed = _speed(ours.column("t"), ours.column("x"))
    assert 0.6 <= speed <= 1.0
    assert abs(speed - _speed(theirs.t, theirs.x)) <= 0.02


def test_bound_cli_runs_the_authors_run_on_their_robot():
    """`bound --host spined-dog --gait sine` is `authors_run.bound_config` (their clock, schedule, model,
    start, exact estimator) with the CLI's k_x, step length, duration and engine."""
    from sparc_quad.cli import build_parser
    from sparc_quad.cli.bound import config_from_args

    args = build_parser().parse_args(["bound", "--host", "spined-dog", "--engine", "mujoco", "--gait", "sine",
                                      "--step-length", "0.07", "--kx", "300", "--duration", "3"])
    cfg = config_from_args(args)
    want = authors_config(0.07, 300.0, 3.0, engine="mujoco")  # stop_on_fall and settle aside
    assert cfg.gait == want.gait and cfg.spine == want.spine and cfg.spine_params == want.spine_params
    assert cfg.spine_schedule == want.spine_schedule and cfg.world == want.world
    assert (cfg.spine_timing, cfg.spine_torso_accel, cfg.spine_rate_hz) == ("authors", False, 200.0)
    noisy = config_from_args(build_parser().parse_args(["bound", "--host", "spined-dog", "--gait", "sine",
                                                        "--imu-noise", "0.01"]))
    assert noisy.world.imu.q1_noise_rad == 0.01
    solo = config_from_args(build_parser().parse_args(["bound", "--gait", "sine"]))
    # gait A elsewhere is the literal port on the authors' gains and schedule (one default with the study)
    assert solo.gait.variant == "literal" and solo.spine_timing == "hold" and solo.spine.k[0] == 800.0
    # the base's motion: what their code feeds their law on their run, the paper's fixed origin elsewhere
    assert cfg.world.base_motion == "authors-cvel" and solo.world.base_motion == "fixed"
    fixed = config_from_args(build_parser().parse_args(["bound", "--host", "spined-dog", "--gait", "sine",
                                                        "--base-motion", "fixed"]))
    assert fixed.world.base_motion == "fixed"
    moving = config_from_args(build_parser().parse_args(["bound", "--base-motion", "constant-twist"]))
    assert moving.world.base_motion == "constant-twist"
    for motion in ("constant-twist", "authors-cvel"):
        args = ["bound", "--host", "spined-dog", "--gait", "sine", "--base-motion", motion]
        assert config_from_args(build_parser().parse_args(args)).world.base_motion == motion
    assert config_from_args(build_parser().parse_args(["bound"])).world.base_motion == "fixed"


def test_the_spine_node_receives_the_schedule_as_commands():
    """Through the spine node (`bound --spine node`) the schedule is what the robot side commands: k0, d0,
    x_d0 first, the run's gains and x_d1 from the switch; q̈1 is sent as 0."""
    from sparc_quad.robot_side.quad import NodeSpine
    from sparc_quad.sim.quadruped_world import EstimatorOutput

    cfg = authors_config(0.07, 300.0, 5.0)
    sch = cfg.spine_schedule
    sp = NodeSpine.inprocess(cfg.spine, False, node_config=authors_run.node_config(), schedule=sch,
                             spine=cfg.spine_params, torso_accel=False)
    try:
        c = sp.robot.command
        assert list(c.k) == list(cfg.spine.k) and list(c.d) == list(sch.d0)
        assert list(c.x_d) == [sch.x_d0_m, sch.z_d_m, 0.0]
        est = EstimatorOutput(0.0, 0.1, 250.0)
        sp.begin(est, [-0.6, 1.2, -0.6], [0.0, 0.0, 0.0], 3.999)
        sp.finish()
        assert sp.robot.command is c and sp.body.torso().ddq1 == 0.0
        sp.begin(est, [-0.6, 1.2, -0.6], [0.0, 0.0, 0.0], 4.0)
        sp.finish()
        c = sp.robot.command
        assert list(c.d) == list(cfg.spine.d) and list(c.x_d) == [sch.x_d1_m, sch.z_d_m, 0.0]
    finally:
        sp.close()


@pytest.mark.slow
def test_the_node_path_runs_the_authors_bound():
    """The same run with the spine node in the loop (1 kHz, in process, not on their 5 ms clock) runs 20 s
    at 0.6-1.0 m/s, as the direct path does (speeds: notebook/2026-12-07-test-docstring-figures.md)."""
    from sparc_quad.robot_side.quad import NodeSpine

    cfg = replace(authors_config(0.07, 300.0, 20.0), stop_on_fall=True)
    sp = NodeSpine.inprocess(cfg.spine, False, node_config=authors_run.node_config(),
                             schedule=cfg.spine_schedule, spine=cfg.spine_params, torso_accel=False)
    r = run_bound(cfg, spine=sp)
    assert not r.metrics["fell"]
    assert 0.6 <= _speed(r.column("t"), r.column("x")) <= 1.0
