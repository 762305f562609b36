"""The emulated torso estimator's imperfections: a small module of its own, so command-line defaults can be
read without importing pybullet (`sparc_quad.sim.quadruped_world` applies them)."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class ImuConfig:
    """What the emulated estimator adds to the true hind-body pitch state (1 sigma noise, constant bias).

    `delay_steps` whole physics steps of latency. q̈1 is the finite difference of the (noisy) rate,
    low-passed with `accel_filter_hz` as an estimator would.
    """

    q1_noise_rad: float = 0.002
    dq1_noise_rad_s: float = 0.01
    ddq1_noise_rad_s2: float = 0.5
    q1_bias_rad: float = 0.0
    dq1_bias_rad_s: float = 0.0
    delay_steps: int = 1
    accel_filter_hz: float = 20.0
