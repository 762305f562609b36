"""Stand-in trial function over today's `run_bound` (Raibert bound), used only while
`sparc_quad.study.trial` (the gait families, power metrics) is not in the package.

It knows the `raibert` gait and the impedance/rigid spines; it reports today's |tau * dq| cost of
transport (cot_abs_*) and per-stride values, nothing it cannot measure.
"""

from __future__ import annotations

import itertools

import numpy as np


def run_trial(config: dict) -> dict:
    from sparc_quad.gaits.bound import BoundParams
    from sparc_quad.sim.bound_run import COLUMNS, BoundConfig, run_bound
    from sparc_quad.sim.quadruped_world import WorldConfig
    from sparc_quad.sim.spine_drive import SpineGains
    from spine_module import params as P

    c = dict(config)
    gait = c.pop("gait", "raibert")
    if gait != "raibert":
        raise ValueError(f"gait {gait!r}: the run_bound adapter only runs 'raibert'")
    spine = c.pop("spine", "impedance")
    if spine not in ("impedance", "rigid"):
        raise ValueError(f"spine {spine!r}: the run_bound adapter only runs 'impedance' and 'rigid'")
    k = [c.pop(n, P.K_DEFAULT[i]) for i, n in enumerate(("kx", "kz", "kth"))]
    d = [c.pop(n, P.D_DEFAULT[i]) for i, n in enumerate(("dx", "dz", "dth"))]
    params = BoundParams(
        frequency_hz=c.pop("frequency", 4.0),
        speed_m_s=c.pop("speed", 0.9),
        step_height_m=c.pop("step_height", 0.07),
        duty=c.pop("duty", None),
    )
    world = WorldConfig(slope_rad=c.pop("slope", 0.0), seed=int(c.pop("seed", 0)))
    cfg = BoundConfig(
        duration_s=float(c.pop("duration", 10.0)),
        gait=params,
        world=world,
        spine=SpineGains(k=tuple(k), d=tuple(d)),
        rigid_spine=spine == "rigid",
        stop_on_fall=True,
        settle_s=min(2.0, 0.2 * float(config.get("duration", 10.0))),
    )
    if c:
        raise ValueError(f"options {sorted(c)} are not known to the run_bound adapter")
    res = run_bound(cfg)
    m = res.metrics
    s = res.series
    col = {name: s[:, i] for i, name in enumerate(COLUMNS)}
    mass = m["mass_kg"]
    out = {
        "fell": m["fell"],
        "fall_time_s": m["fall_time_s"],
        "fall_reason": m["fall_reason"],
        "speed_m_s": m.get("mean_speed_m_s"),
        "stride_frequency_hz": m.get("stride_frequency_hz"),
        "stride_length_m": m.get("stride_length_m"),
        "gait_frequency_hz": params.frequency_hz,
        "mass_kg": mass,
        "cot_abs_total": m.get("cost_of_transport"),
    }
    dist = m.get("distance_m")
    if dist and abs(dist) > 1e-6 and "mean_power_w" in m:
        span = m["window_s"][1] - m["window_s"][0]
        for part in ("legs", "spine"):
            out[f"cot_abs_{part}"] = m["mean_power_w"][part] * span / (mass * P.GRAVITY_M_S2 * abs(dist))
    strides = []
    t0 = m["window_s"][0]
    w = np.flatnonzero(col["t"] >= t0)
    if len(w) > 10:
        c_hl = col["contact_HL"][w] > 0.5
        tds = w[np.flatnonzero(c_hl[1:] & ~c_hl[:-1]) + 1]
        dt = cfg.world.dt_s
        for a, b in itertools.pairwise(tds):
            dx = col["x"][b] - col["x"][a]
            e_legs = col["leg_power_w"][a:b].sum() * dt
            e_spine = col["spine_power_w"][a:b].sum() * dt
            if abs(dx) < 1e-6:
                continue
            strides.append(
                {
                    "t_s": float(col["t"][a]),
                    "period_s": float((b - a) * dt),
                    "length_m": float(dx),
                    "cot_abs_total": float((e_legs + e_spine) / (mass * P.GRAVITY_M_S2 * abs(dx))),
                    "cot_abs_legs": float(e_legs / (mass * P.GRAVITY_M_S2 * abs(dx))),
                    "cot_abs_spine": float(e_spine / (mass * P.GRAVITY_M_S2 * abs(dx))),
                }
            )
    out["strides"] = strides
    return out
