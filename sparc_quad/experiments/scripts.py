"""The bench experiments as robot-side scripts: what the torso computer commands and the rig pushes."""

from __future__ import annotations

import numpy as np

from sparc_quad.experiments.static import StaticConfig
from sparc_quad.robot_side.scripts import BenchScript
from sparc_quad.sim.forces import push_pull
from spine_module import params as P
from spine_module.messages import Mode, SpineCommand


def hold_script(duration_s: float = 1.0, k: tuple[float, float, float] = tuple(P.K_DEFAULT),
                d: tuple[float, float, float] = tuple(P.D_DEFAULT)) -> BenchScript:
    cmd = SpineCommand(mode=Mode.IMPEDANCE, k=np.array(k, dtype=float), d=np.array(d, dtype=float))
    return BenchScript(command=cmd, duration_s=duration_s)


_STATIC = StaticConfig()


def static_push_script(k_x: float = 500.0, amplitude_m: float = _STATIC.amplitude_m,
                       period_s: float = _STATIC.period_s, cycles: float = 1.0, k_z: float = _STATIC.k_z,
                       k_theta: float = _STATIC.k_theta,
                       d: tuple[float, float, float] = _STATIC.d) -> BenchScript:
    """Section IV-A's push-pull, the same force law as `sparc-quad bench static`."""
    force = push_pull(k_x * amplitude_m, period_s)
    cmd = SpineCommand(mode=Mode.IMPEDANCE, k=np.array([k_x, k_z, k_theta]), d=np.array(d, dtype=float))
    return BenchScript(command=cmd, force=force, duration_s=cycles * period_s)
