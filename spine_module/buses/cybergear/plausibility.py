"""Is a CyberGear feedback frame physically possible? A glitch must latch, never reach the controller.

One bad encoder or velocity reading (a +2 rad step, a 29 rad/s spike) fed to the impedance law gives full
torque on every joint. The backend therefore checks each feedback frame against the previous one of the
same motor and against the joint's range, and latches a named fault (stop frames to every motor) on the
first frame that fails. The bounds, all joint side:

- position inside the joint's range (`params.JOINT_LOWER/UPPER_RAD`) widened by `range_margin_rad`
  (0.3 rad: the node's joint-limit damping acts 0.1 rad inside the limit, so a working spine ends well
  inside this; beyond it the reading is a glitch or the joint is mis-zeroed);
- a position step no larger than the CyberGear's top speed over the time since the previous frame plus
  `jump_tolerance_rad` (0.1 rad: several periods of bunched frames at 30 rad/s, 250 position LSBs);
- a velocity step no larger than `accel_max_rad_s2` over that time plus `velocity_tolerance_rad_s`
  (10000 rad/s^2 is 1.5x what 12 N*m gives the reflected rotor inertia alone, 12 / 1.8e-3 = 6700 rad/s^2;
  the tolerance covers the motors' velocity noise);
- velocity not at the frame's saturated end (+-30 rad/s motor side: a reading there says nothing but
  "at least this fast"), torque estimate within the configured `limit_torque_nm` plus 10 %.

The time between two frames of a motor is taken from the frames' receive stamps (python-can's
`Message.timestamp`: the kernel's or the adapter's), or from the backend's stamp clock when a simulation
gives one (its motors move in simulated time), so a host that processes bunched frames late is judged on
the frames' time, not on its own delay.
"""

from __future__ import annotations

from dataclasses import dataclass

from spine_module.params import CYBERGEAR, JOINT_LOWER_RAD, JOINT_UPPER_RAD


@dataclass(frozen=True)
class PlausibilityLimits:
    range_margin_rad: float = 0.3
    jump_tolerance_rad: float = 0.1
    accel_max_rad_s2: float = 10_000.0
    velocity_tolerance_rad_s: float = 5.0
    torque_margin: float = 0.10  # fraction of limit_torque_nm a torque estimate may exceed it by
    check_range: bool = True  # rigs whose free plants are not a spine (no joint range) turn it off


DEFAULT_LIMITS = PlausibilityLimits()


@dataclass
class Reading:
    """One motor's last accepted feedback, joint side."""

    q_rad: float
    dq_rad_s: float
    stamp_s: float


def implausible(name: str, gear_ratio: float, limit_torque_nm: float, prev: Reading | None, q_rad: float,
                dq_rad_s: float, tau_nm: float, stamp_s: float, velocity_motor_rad_s: float,
                limits: PlausibilityLimits = DEFAULT_LIMITS) -> str | None:
    """Why this frame cannot be true (one phrase naming the quantity), or None if it can."""
    lo, hi = JOINT_LOWER_RAD[name] - limits.range_margin_rad, JOINT_UPPER_RAD[name] + limits.range_margin_rad
    if limits.check_range and not lo <= q_rad <= hi:
        return (f"position {q_rad:.4g} rad outside [{lo:.4g}, {hi:.4g}] (joint range +- "
                f"{limits.range_margin_rad:g})")
    v_end = CYBERGEAR.velocity_rad_s * (1.0 - 1e-4)  # within one LSB (2 x 30 / 65535) of the frame's end
    if abs(velocity_motor_rad_s) >= v_end:
        return (f"velocity {dq_rad_s:.4g} rad/s at the frame's saturated end "
                f"(+-{CYBERGEAR.velocity_rad_s:g} rad/s motor side)")
    tau_max = limit_torque_nm * gear_ratio * (1.0 + limits.torque_margin)
    if abs(tau_nm) > tau_max:
        return f"torque estimate {tau_nm:.4g} N*m beyond {tau_max:.4g} N*m (limit_torque_nm + 10 %)"
    if prev is None:
        return None
    dt = max(stamp_s - prev.stamp_s, 0.0)
    v_max = CYBERGEAR.velocity_rad_s / gear_ratio
    jump = abs(q_rad - prev.q_rad)
    if jump > v_max * dt + limits.jump_tolerance_rad:
        return (f"position jumped {jump:.4g} rad in {dt * 1e3:.3g} ms (at most {v_max:g} rad/s + "
                f"{limits.jump_tolerance_rad:g} rad)")
    dv = abs(dq_rad_s - prev.dq_rad_s)
    if dv > limits.accel_max_rad_s2 * dt + limits.velocity_tolerance_rad_s:
        return (f"velocity jumped {dv:.4g} rad/s in {dt * 1e3:.3g} ms (at most {limits.accel_max_rad_s2:g} "
                f"rad/s^2 + {limits.velocity_tolerance_rad_s:g} rad/s)")
    return None


__all__ = ["DEFAULT_LIMITS", "PlausibilityLimits", "Reading", "implausible"]
