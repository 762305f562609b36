"""Energetics and gait metrics of a bound over its steady window, per trial and per stride (issue 13).

Joint power P_j = tau_j * qdot_j (W) for each of the 12 leg joints and 3 spine joints. With m the robot's
mass, g gravity and d the distance travelled along the ground over the window:

- CoT_pos  = integral of sum_j max(P_j, 0) / (m g d): actuators pay for positive work, negative work is
  lost as heat (the headline);
- CoT_abs  = integral of sum_j |P_j| / (m g d): the project's older metric (negative work also paid);
- CoT_net  = integral of sum_j P_j / (m g d): perfect regeneration (can be negative);
- CoT_elec = integral of sum_j max(P_j + c_j tau_j^2, 0) / (m g d): the winding (I^2 R) loss added, with
  c_j from the actuator's torque constant and resistance (params.WindingLoss: Solo12 for the legs,
  CyberGear for the spine), no regeneration to the supply.

Each is split `legs`, `spine`, `total`. A spine that is not an actuator (passive spring, locked joint)
costs 0; its own work is still reported (`spine_work_*`, the passivity check). Strides start where the gait
clock wraps; a window shorter than two strides gives `window_ok: False` and a `warning`.
"""

from __future__ import annotations

import math
import warnings

import numpy as np

from sparc_quad.sim.bound_log import COLUMNS, LEG_JOINTS
from spine_module import params as P

GROUPS = ("legs", "spine", "total")
COTS = ("pos", "abs", "net", "elec")


def power_terms(tau: np.ndarray, dq: np.ndarray, loss_w_per_nm2: float | np.ndarray) -> dict[str, np.ndarray]:
    """Per-sample power summed over joints (W), columns = joints: pos, abs, net, elec."""
    p = tau * dq
    pe = p + np.asarray(loss_w_per_nm2) * tau * tau
    return {
        "pos": np.clip(p, 0.0, None).sum(axis=1),
        "abs": np.abs(p).sum(axis=1),
        "net": p.sum(axis=1),
        "elec": np.clip(pe, 0.0, None).sum(axis=1),
    }


def cost_of_transport(energy_j: float, mass_kg: float, distance_m: float, g: float = P.GRAVITY_M_S2) -> float:
    """energy / (m g d); NaN when the robot did not move (|d| < 1 mm)."""
    return energy_j / (mass_kg * g * abs(distance_m)) if abs(distance_m) > 1e-3 else float("nan")


def dominant_frequency_hz(x: np.ndarray, dt: float) -> float:
    """The frequency of the largest peak of x's spectrum (mean removed, Hann window); NaN if flat
    (peak-to-peak < 1e-5)."""
    if len(x) < 16 or float(np.ptp(x)) < 1e-5:  # a locked joint jitters by ~1e-6
        return float("nan")
    y = (x - x.mean()) * np.hanning(len(x))
    spec = np.abs(np.fft.rfft(y))
    freqs = np.fft.rfftfreq(len(x), dt)
    spec[0] = 0.0
    return float(freqs[int(np.argmax(spec))])


def amplitude(x: np.ndarray) -> float:
    """Half the 2.5-97.5 percentile range (robust half peak-to-peak)."""
    if len(x) == 0:
        return float("nan")
    lo, hi = np.percentile(x, [2.5, 97.5])
    return float(0.5 * (hi - lo))


def stride_starts(phase_cycles: np.ndarray) -> np.ndarray:
    """Indices where the gait clock (cycles in [0, 1)) wraps: each is the first sample of a stride."""
    return np.flatnonzero(np.diff(phase_cycles) < -0.5) + 1


_BLOCK_KEYS = (
    *(f"cot_{c}_{g}" for c in COTS for g in GROUPS), *(f"power_{c}_{g}_w" for c in COTS for g in GROUPS),
    "cot_pos", "cot_abs", "cot_net", "cot_elec", "duration_s", "distance_m", "speed_m_s", "spine_work_j",
    "spine_work_plus_spring_energy_change_j", "duty_mean", "duty_hind", "duty_front", "flight_time_s",
    "spine_x_amplitude_m", "spine_theta_amplitude_rad",
)
_TRIAL_KEYS = (
    "window_length_s", "stride_frequency_hz", "stride_length_m", "spine_work_per_stride_j",
    "commanded_gait_frequency_hz", "spine_x_dominant_hz", "spine_theta_dominant_hz",
    "spine_x_dominant_over_gait", "peak_leg_torque_nm", "leg_saturation_share", "peak_spine_torque_nm",
    "spine_torque_rms_nm", "spine_saturation_share",
)


def empty_metrics() -> dict:
    """Every trial-level metric as NaN: what a trial without a steady window reports."""
    return dict.fromkeys((*_BLOCK_KEYS, *_TRIAL_KEYS), float("nan"))


def _columns():
    idx = {name: k for k, name in enumerate(COLUMNS)}
    return idx, LEG_JOINTS


def study_metrics(s: np.ndarray, cfg, mass: float, actuated: bool, t_start: float) -> dict:
    """Flat metrics (JSON-able, NaN where undefined) + `strides`: a list of per-stride dicts."""
    idx, leg_joints = _columns()
    dt = cfg.world.dt_s
    g = P.GRAVITY_M_S2
    nan = float("nan")
    out: dict = {**empty_metrics(), "window_ok": False, "n_strides": 0, "spine_actuated": actuated}
    if len(s) == 0:
        return _no_window(out, "no samples")
    t = s[:, idx["t"]]
    w = np.flatnonzero(t >= t_start)
    tau_legs = s[:, idx["tau_HL_haa"]: idx["tau_HL_haa"] + len(leg_joints)]
    dq_legs = s[:, idx["dq_HL_haa"]: idx["dq_HL_haa"] + len(leg_joints)]
    tau_sp = s[:, idx["tau2"]: idx["tau2"] + 3]
    dq_sp = s[:, idx["dq2"]: idx["dq2"] + 3]
    legs = power_terms(tau_legs, dq_legs, P.SOLO12_WINDING.loss_w_per_nm2)
    spine_raw = power_terms(tau_sp, dq_sp, P.CYBERGEAR_WINDING.loss_w_per_nm2)
    spine = spine_raw if actuated else {k: np.zeros(len(s)) for k in COTS}
    p_spine_net = (tau_sp * dq_sp).sum(axis=1)  # the spine torque's power on the joints, actuator or not
    x_along = s[:, idx["x"]] / math.cos(cfg.world.slope_rad)
    phase = s[:, idx["gait_phase"]]
    starts = stride_starts(phase)
    starts = starts[starts >= (w[0] if len(w) else len(s))]
    contacts = s[:, [idx[f"contact_{k}"] for k in ("HL", "HR", "FL", "FR")]] > 0.5
    energy_spring = s[:, idx["spine_spring_energy_j"]]
    lim_legs = float(cfg_leg_limit(cfg))

    def block(a: int, b: int) -> dict:
        """Metrics over samples [a, b)."""
        m: dict = {}
        span = (b - a) * dt
        dist = float(x_along[b - 1] - x_along[a]) if b - a > 1 else 0.0
        m["duration_s"] = span
        m["distance_m"] = dist
        m["speed_m_s"] = dist / span if span > 0 else nan
        for c in COTS:
            e_l = float(legs[c][a:b].sum() * dt)
            e_s = float(spine[c][a:b].sum() * dt)
            for grp, e in (("legs", e_l), ("spine", e_s), ("total", e_l + e_s)):
                m[f"cot_{c}_{grp}"] = cost_of_transport(e, mass, dist, g)
                m[f"power_{c}_{grp}_w"] = e / span if span > 0 else nan
        m["cot_pos"] = m["cot_pos_total"]
        m["cot_abs"] = m["cot_abs_total"]
        m["cot_net"] = m["cot_net_total"]
        m["cot_elec"] = m["cot_elec_total"]
        m["spine_work_j"] = float(p_spine_net[a:b].sum() * dt)
        # the spring-damper's work minus its stored energy's release: <= 0 for a passive element
        m["spine_work_plus_spring_energy_change_j"] = m["spine_work_j"] + float(
            energy_spring[b - 1] - energy_spring[a]) if b - a > 1 else nan
        c = contacts[a:b]
        m["duty_mean"] = float(c.mean()) if len(c) else nan
        m["duty_hind"] = float(c[:, :2].mean()) if len(c) else nan
        m["duty_front"] = float(c[:, 2:].mean()) if len(c) else nan
        m["flight_time_s"] = float((~c.any(axis=1)).sum() * dt)
        m["spine_x_amplitude_m"] = amplitude(s[a:b, idx["spine_x"]])
        m["spine_theta_amplitude_rad"] = amplitude(s[a:b, idx["spine_theta"]])
        return m

    if len(w) < 2:
        return _no_window(out, "steady window is empty (0 complete strides): the trial ended or fell "
                               "before its start-up was over")
    a, b = int(w[0]), len(s)
    whole = block(a, b)
    strides = []
    for k in range(len(starts) - 1):
        sa, sb = int(starts[k]), int(starts[k + 1])
        st = block(sa, sb)
        st["t_start_s"] = float(t[sa])
        st["frequency_hz"] = 1.0 / st["duration_s"]
        st["stride_length_m"] = st["distance_m"]
        st["flight_time_fraction"] = st["flight_time_s"] / st["duration_s"]
        strides.append(st)
    n_str = len(strides)
    out.update(whole)
    out["window_length_s"] = float(b - a) * dt
    out["n_strides"] = n_str
    out["window_ok"] = n_str >= 2
    if not out["window_ok"]:
        msg = (f"steady window {out['window_length_s']:.2f} s holds {n_str} complete strides (< 2): "
               "gait metrics are not meaningful; run longer")
        out["warning"] = msg
        warnings.warn(msg, RuntimeWarning, stacklevel=3)
    if n_str:
        out["stride_frequency_hz"] = float(np.mean([x["frequency_hz"] for x in strides]))
        out["stride_length_m"] = float(np.mean([x["stride_length_m"] for x in strides]))
        out["flight_time_s"] = float(np.mean([x["flight_time_s"] for x in strides]))
        out["spine_work_per_stride_j"] = float(np.mean([x["spine_work_j"] for x in strides]))
    else:
        out["stride_frequency_hz"] = nan
        out["stride_length_m"] = nan
        out["spine_work_per_stride_j"] = nan
    gait_f = float(s[a:b, idx["gait_frequency_hz"]].mean())
    out["commanded_gait_frequency_hz"] = gait_f
    fx = dominant_frequency_hz(s[a:b, idx["spine_x"]], dt)
    fth = dominant_frequency_hz(s[a:b, idx["spine_theta"]], dt)
    out["spine_x_dominant_hz"] = fx
    out["spine_theta_dominant_hz"] = fth
    out["spine_x_dominant_over_gait"] = fx / gait_f if gait_f > 0 else nan
    # torques: peaks and how often an actuator sat at its limit
    tl = np.abs(tau_legs[a:b])
    ts = np.abs(tau_sp[a:b])
    out["peak_leg_torque_nm"] = float(tl.max())
    out["leg_saturation_share"] = float((tl >= lim_legs - 1e-6).any(axis=1).mean())
    out["peak_spine_torque_nm"] = float(ts.max())
    out["spine_torque_rms_nm"] = float(np.sqrt((ts**2).mean()))  # the holding torque of rigid-impedance
    out["spine_saturation_share"] = float((ts >= P.TORQUE_LIMIT_NM - 1e-6).any(axis=1).mean())
    out["spine_actuated"] = actuated
    out["strides"] = strides
    return out


def _no_window(out: dict, msg: str) -> dict:
    out["warning"] = msg
    out["strides"] = []
    warnings.warn(msg, RuntimeWarning, stacklevel=3)
    return out


def cfg_leg_limit(cfg) -> float:
    from sparc_quad.sim.quadruped_urdf import HOSTS

    return HOSTS[cfg.world.host].leg_torque_limit_nm
