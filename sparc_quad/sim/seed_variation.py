"""What a study seed changes: small physical and timing differences between replicate trials.

Seed 0 is the nominal trial (no perturbation; the IMU noise realisation of seed 0). Any other seed draws,
from its own generator, deterministically: the gait clock's start phase, initial body pitch and forward
velocity, every link's mass (and inertia) scale (+-2 %), ground friction (+-10 %); the world's generator,
seeded with the seed, draws the IMU noise. Actuator latency is NOT a seed: it changes the regime (at 2 ms
the rigid spine's CoT went 0.58 -> 3.67), so it is a study factor (`latency_steps`, default 0).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

# ranges (uniform): small disturbances a real replicate would see
PITCH_RAD = 0.03
VX_M_S = 0.05
START_PHASE_CYCLES = 0.05  # +- this fraction of a stride: an open-loop gait's designed start stays near
FRICTION = (0.9, 1.1)
MASS_SCALE = (0.98, 1.02)


@dataclass(frozen=True)
class Perturbation:
    init_pitch_rad: float = 0.0
    init_vx_m_s: float = 0.0
    start_phase_cycles: float = 0.0  # fraction of a stride (signed)
    friction: float = 1.0  # times the nominal foot-ground coefficient
    mass_scale: float = 1.0

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
        start_phase_cycles=float(rng.uniform(-START_PHASE_CYCLES, START_PHASE_CYCLES)),
        friction=float(rng.uniform(*FRICTION)),
        mass_scale=float(rng.uniform(*MASS_SCALE)),
    )
