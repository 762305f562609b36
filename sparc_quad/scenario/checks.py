"""What a scenario asks that its robot and engine cannot do, found before it runs: the same refusal for
`sparc-quad bound`, a study cell and Python (`resolve.bound_config` calls it)."""

from __future__ import annotations

import json
import math

from sparc_quad.gaits.bound import BoundParams
from sparc_quad.gaits.sine_bound import SineBoundParams
from sparc_quad.scenario.model import ScenarioError
from sparc_quad.sim.engines import engine_error, world_class
from sparc_quad.sim.hosts import host_files
from sparc_quad.sim.quadruped_world import twist_lag_problem


def check_runnable(cfg) -> None:
    """ScenarioError naming the key when the legs cannot walk the gait (gait A's foot targets beyond their
    reach; a Raibert stance longer than the legs sweep at the hip height, so the target speed is out of
    reach whatever the controller does) or the engine cannot feed the estimator (`authors-cvel` reads
    MuJoCo's cvel one step late, so the estimate must be at least that late)."""
    legs = json.loads(host_files(cfg.world.host).meta.read_text())["legs"].values()
    reach = min(leg["thigh_m"] + leg["shank_m"] for leg in legs)
    gait = cfg.gait
    if not isinstance(gait, BoundParams):
        sine = isinstance(gait, SineBoundParams)
        try:
            gait.validate(reach)
        except ValueError as exc:
            raise ScenarioError("step_length" if sine else "gait",
                                f"gait {'sine' if sine else 'authors-raibert'}: {exc}") from None
    elif reach > gait.height_m:
        sweep_max = 2.0 * math.sqrt(reach**2 - gait.height_m**2)  # foot travel under the hip in one stance
        duty = gait.duty_at(gait.speed_m_s)
        sweep = gait.speed_m_s * duty / gait.frequency_hz
        if sweep > sweep_max:
            top = sweep_max * gait.frequency_hz / duty
            raise ScenarioError("speed", f"{gait.speed_m_s:g} m/s at {gait.frequency_hz:g} Hz needs a stance "
                                         f"stride of {sweep:.3f} m; the legs ({reach:.3f} m at hip height "
                                         f"{gait.height_m:g} m) sweep at most {sweep_max:.3f} m: at most "
                                         f"about {top:.2f} m/s")
    w = cfg.world
    if w.base_motion == "authors-cvel" and engine_error(w.engine) is None:
        problem = twist_lag_problem(w.base_motion, world_class(w.engine).cvel_lag_steps, w.imu.delay_steps)
        if problem is not None:
            raise ScenarioError("imu_delay", f"base_motion authors-cvel with engine {w.engine}: {problem} "
                                             "(give imu_delay 1 or more, or another base_motion)")
