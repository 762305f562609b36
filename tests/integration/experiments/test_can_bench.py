"""The static bench experiment through real CAN frames: controller -> CanMotorBus -> python-can `virtual`
bus -> emulated CyberGears (lockstep) -> pybullet bench spine, against the same 1.5 % stiffness criterion
as in-process, and against the in-process result itself."""

from __future__ import annotations

import pytest

from sparc_quad.experiments import rig, static
from sparc_quad.experiments.stats import ols
from sparc_quad.sim.cybergear_bench import static_trial_over_can
from spine_module import params as P
from spine_module.model import SpineModel


@pytest.mark.parametrize("k", [500.0])
def test_static_stiffness_over_can(k):
    cfg = static.StaticConfig(cycles=1)  # one 8 s push-pull: ~800 (x, F) pairs
    model = SpineModel()
    ctrl = rig.make_controller(cfg.controller, model, (k, cfg.k_z, cfg.k_theta), cfg.d)
    log = static_trial_over_can(ctrl, cfg.cycles * cfg.period_s,
                                static.push_pull(k * cfg.amplitude_m, cfg.period_s), plant=cfg.plant,
                                seed=cfg.seed, sample_every=cfg.sample_every)
    assert log.emulator_rejected == 0
    assert log.tx_frames >= 3 * log.cycles and log.rx_frames >= 3 * log.cycles
    fit = ols(log.x_meas[:, 0] - P.X_EQUILIBRIUM[0], log.f_cell)
    rel_err = abs(fit.slope - k) / k
    assert rel_err < 0.015, (fit.slope, fit.r2)
    assert fit.r2 > 0.99
    inproc, _, _ = static.measure_stiffness(k, cfg, model)
    assert abs(fit.slope - inproc.k_hat) / k < 0.005  # the bus changes the result by < 0.5 % of k


@pytest.mark.slow
@pytest.mark.parametrize("k", [300.0, 400.0, 500.0, 600.0, 700.0])
def test_static_table_over_can(k):
    """The paper's full Table IV protocol (two 8 s push-pulls per k) over CAN frames."""
    cfg = static.StaticConfig()
    model = SpineModel()
    ctrl = rig.make_controller(cfg.controller, model, (k, cfg.k_z, cfg.k_theta), cfg.d)
    log = static_trial_over_can(ctrl, cfg.cycles * cfg.period_s,
                                static.push_pull(k * cfg.amplitude_m, cfg.period_s), plant=cfg.plant,
                                seed=cfg.seed, sample_every=cfg.sample_every)
    fit = ols(log.x_meas[:, 0] - P.X_EQUILIBRIUM[0], log.f_cell)
    assert abs(fit.slope - k) / k < 0.015 and fit.r2 > 0.99
