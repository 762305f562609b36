"""What a study seed changes: real physical and timing differences between trials, not only sensor noise.

Seed 0 is the nominal trial (no perturbation, the IMU noise of seed 0). Any other seed draws, from its own
generator, deterministically: initial body pitch, initial forward velocity, the gait clock's start phase,
ground friction, every link's mass (and inertia) scale, and a whole-millisecond actuator latency.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

# ranges (uniform unless said): chosen to be small disturbances a real trial would see
PITCH_RAD = 0.03
VX_M_S = 0.05
FRICTION = (0.8, 1.2)
MASS_SCALE = (0.95, 1.05)
LATENCY_STEPS = (0, 1, 2)  # 1 ms steps, equally likely


@dataclass(frozen=True)
class Perturbation:
    init_pitch_rad: float = 0.0
    init_vx_m_s: float = 0.0
    start_phase_cycles: float = 0.0  # fraction of a stride
    friction: float = 1.0
    mass_scale: float = 1.0
    latency_steps: int = 0

    def as_metrics(self) -> dict:
        return {f"seed_{k}": v for k, v in asdict(self).items()}


def perturbation(seed: int) -> Perturbation:
    """The perturbation of trial `seed` (seed 0: none)."""
    if int(seed) != seed or seed < 0:
        raise ValueError(f"seed must be a non-negative integer, got {seed!r}")
    if seed == 0:
        return Perturbation()
    rng = np.random.default_rng([int(seed), 0x5EED])
    return Perturbation(
        init_pitch_rad=float(rng.uniform(-PITCH_RAD, PITCH_RAD)),
        init_vx_m_s=float(rng.uniform(-VX_M_S, VX_M_S)),
        start_phase_cycles=float(rng.uniform(0.0, 1.0)),
        friction=float(rng.uniform(*FRICTION)),
        mass_scale=float(rng.uniform(*MASS_SCALE)),
        latency_steps=int(rng.choice(LATENCY_STEPS)),
    )
