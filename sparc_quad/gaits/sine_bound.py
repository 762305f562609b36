"""Gait family A: the SPARC authors' open-loop sine bound, ported to the Solo12 host.

The authors' bound (github YueWang996/sparc, `mujoco_simulation/dog_controller_no_cpg.py` and
`main_robot.py`): each foot follows, relative to its hip, x = L cos(phi), z = H sin(phi) while sin(phi) > 0
(swing) and z = 0 otherwise (stance, duty 0.5), offset `hip_depth_m` below the hip; leg phases offset
[0, 0, pi, pi] (HL, HR, FL, FR); joint targets by inverse kinematics, tracked by a joint PD (Kp 8 N*m/rad,
Kd 0.1 N*m*s/rad, zero velocity target). Speed is emergent. Steering: once per cycle a yaw PD sets a
left/right stride asymmetry (clipped to +-40 %). Frequency adaptation (option): the gait phase at each
peak of the (6 Hz low-passed) spine extension x is recorded from 2 s until the spine switch (4 s); its
circular mean is the target; afterwards, when the peak lags the target by more than 0.1 rad, the frequency
is lowered by 1 Hz/rad of lag (smoothed 1:1, within 2.8-3.2 Hz), applied at the next cycle start.

Port to Solo12 (0.16 m thigh and shank, the authors' dog has 0.151 m): L = 0.12 m, H = 0.06 m and the
0.23 m depth are kept; the farthest foot target is sqrt(0.12^2 + 0.23^2) = 0.259 m, 81 % of the 0.32 m
reach, so no scaling is needed. x is forward, as written in the authors' code (`direction` = +1): the
raised arc runs x = +L -> -L and the flat part -L -> +L. Measured here: with this literal port the robot
moves forward; with the arc reversed (`direction` = -1, the "swing forward" reading) it moves backward.
With Kp = 8 N*m/rad the feet lag their targets far behind, so the contact phases are not the flat part.
Solo12 has hip abduction joints (the authors' dog has none): they are held at 0 by a PD (`haa_kp`,
`haa_kd`). Start-up (not in the authors' code, which starts on the trajectory): stand `start_s`, then the
stride amplitude ramps from 0 to L over `ramp_s`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

LEGS = ("HL", "HR", "FL", "FR")
PHASE_OFFSET = {"HL": 0.0, "HR": 0.0, "FL": math.pi, "FR": math.pi}


@dataclass(frozen=True)
class SineBoundParams:
    frequency_hz: float = 3.1  # initial gait frequency
    step_length_m: float = 0.12  # L: half the fore-aft foot excursion relative to the hip
    step_height_m: float = 0.06  # H: swing clearance
    hip_depth_m: float = 0.23  # foot below the hip in stance
    kp_nm_rad: float = 8.0  # joint PD on HFE and KFE
    kd_nm_s_rad: float = 0.1
    haa_kp_nm_rad: float = 15.0  # abduction held at 0 (Solo12 only)
    haa_kd_nm_s_rad: float = 0.4
    yaw_kp: float = 0.3  # stride asymmetry per rad of heading error, once per cycle
    yaw_kd: float = 0.1
    adapt_frequency: bool = False  # the authors' phase-of-peak-extension frequency adaptation
    adapt_gain_hz_rad: float = 1.0
    adapt_min_hz: float = 2.8
    adapt_max_hz: float = 3.2
    adapt_calibrate_from_s: float = 2.0
    adapt_switch_s: float = 4.0  # calibration ends, adaptation starts (the spine switch time)
    direction: float = 1.0  # +1: the authors' code literally; -1: the foot arc reversed
    start_phase_rad: float = 0.0  # gait clock at the start of stepping (study seeds vary it)
    start_s: float = 0.3
    ramp_s: float = 1.0
    speed_m_s: float = 0.0  # not a target (speed is emergent); kept for the metrics' window logic
    accel_m_s2: float = 0.0

    def validate(self) -> None:
        reach = math.hypot(self.step_length_m, self.hip_depth_m)
        if self.direction not in (1.0, -1.0):
            raise ValueError(f"direction must be +1 or -1, got {self.direction}")
        if not (0.0 < self.frequency_hz <= 10.0):
            raise ValueError(f"frequency must be in (0, 10] Hz, got {self.frequency_hz}")
        if self.step_length_m < 0 or self.step_height_m < 0 or self.hip_depth_m <= self.step_height_m:
            raise ValueError("step length and height must be >= 0 and the hip depth above the step height")
        if reach >= 0.32:
            raise ValueError(f"foot target {reach:.3f} m from the hip is beyond the 0.32 m leg")


class SineBoundController:
    """Leg torques of the open-loop bound. `step(t)` -> {leg: (tau_haa, tau_hfe, tau_kfe)} N*m."""

    def __init__(self, world, params: SineBoundParams | None = None):
        self.p = p = params or SineBoundParams()
        p.validate()
        self.w = world
        self.dt = world.cfg.dt_s
        self.tau_limit = float(world.meta["leg_torque_limit_nm"])
        self.frequency_hz = p.frequency_hz
        self.phase = p.start_phase_rad  # gait clock, rad (unwrapped)
        self.stride_scale = {"L": 1.0, "R": 1.0}
        self._last_yaw_err = 0.0
        self._pending_f: float | None = None
        self.out = {k: (0.0, 0.0, 0.0) for k in LEGS}
        self.stance_flags = {"hind": True, "front": True}
        self.target_peak_phase: float | None = None
        self._cal_phases: list[float] = []
        self._lp_a = 1.0 - math.exp(-2 * math.pi * 6.0 * self.dt)
        self._x_lp: float | None = None
        self._x_hist = [0.0, 0.0, 0.0]
        self._stand = {k: world.leg_ik(k, 0.0, -p.hip_depth_m) for k in LEGS}
        self.cycle_starts = 0

    @property
    def gait_phase(self) -> float:
        """Gait clock wrapped to [0, 2 pi)."""
        return self.phase % (2 * math.pi)

    def _on_cycle_start(self) -> None:
        p = self.p
        self.cycle_starts += 1
        if self._pending_f is not None:
            self.frequency_hz, self._pending_f = self._pending_f, None
        err = -self.w.yaw  # heading target 0
        cmd = p.yaw_kp * err + p.yaw_kd * (err - self._last_yaw_err)
        self._last_yaw_err = err
        cmd = max(-0.4, min(0.4, cmd))
        self.stride_scale = {"L": 1.0 - cmd, "R": 1.0 + cmd}  # turn left: right strides longer

    def observe_spine(self, t: float, spine_x_m: float) -> None:
        """Feed the spine extension x (m) each step: the frequency adaptation's peak detector."""
        if not self.p.adapt_frequency:
            return
        if self._x_lp is None:
            self._x_lp = spine_x_m
        self._x_lp += self._lp_a * (spine_x_m - self._x_lp)
        h = self._x_hist
        h[0], h[1], h[2] = h[1], h[2], self._x_lp
        if not (h[1] > h[2] and h[1] > h[0]):
            return
        phase_at_peak = (self.phase - 2 * math.pi * self.frequency_hz * self.dt) % (2 * math.pi)
        p = self.p
        if t < p.adapt_switch_s:
            if t > p.adapt_calibrate_from_s:
                self._cal_phases.append(phase_at_peak)
            return
        if self.target_peak_phase is None:
            ph = np.asarray(self._cal_phases)
            self.target_peak_phase = (
                float(math.atan2(np.sin(ph).sum(), np.cos(ph).sum())) if len(ph) else 0.0
            )
            return
        lag = (phase_at_peak - self.target_peak_phase + math.pi) % (2 * math.pi) - math.pi
        if lag > 0.1:
            f_new = min(p.adapt_max_hz, max(p.adapt_min_hz, self.frequency_hz - p.adapt_gain_hz_rad * lag))
            f_s = 0.5 * f_new + 0.5 * self.frequency_hz
            if abs(f_s - self.frequency_hz) > 0.01:
                self._pending_f = f_s

    def step(self, t: float) -> dict[str, tuple[float, float, float]]:
        p, w = self.p, self.w
        running = t >= p.start_s
        amp = min(1.0, (t - p.start_s) / p.ramp_s) if running and p.ramp_s > 0 else float(running)
        if running:
            before = self.phase
            self.phase += 2 * math.pi * self.frequency_hz * self.dt
            if math.floor(self.phase / (2 * math.pi)) != math.floor(before / (2 * math.pi)):
                self._on_cycle_start()
        lim = self.tau_limit
        for leg in LEGS:
            st = w.leg_state(leg)
            if running:
                ph = self.phase + PHASE_OFFSET[leg]
                s = math.sin(ph)
                x = p.direction * amp * p.step_length_m * self.stride_scale[leg[1]] * math.cos(ph)
                z = -p.hip_depth_m + (amp * p.step_height_m * s if s > 0 else 0.0)
                h_d, k_d = w.leg_ik(leg, x, z)
            else:
                h_d, k_d = self._stand[leg]
            tau_haa = -p.haa_kp_nm_rad * st.haa - p.haa_kd_nm_s_rad * st.dhaa
            tau_h = p.kp_nm_rad * (h_d - st.hfe) - p.kd_nm_s_rad * st.dhfe
            tau_k = p.kp_nm_rad * (k_d - st.kfe) - p.kd_nm_s_rad * st.dkfe
            self.out[leg] = (
                max(-lim, min(lim, tau_haa)),
                max(-lim, min(lim, tau_h)),
                max(-lim, min(lim, tau_k)),
            )
        ph = self.phase
        self.stance_flags["hind"] = not running or math.sin(ph) <= 0.0
        self.stance_flags["front"] = not running or math.sin(ph + math.pi) <= 0.0
        return self.out
