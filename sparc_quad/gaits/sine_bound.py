"""Gait family A: the SPARC authors' open-loop sine bound, on any host.

Source: github.com/YueWang996/sparc, commit d9639f5, `mujoco_simulation/main_robot.py` and
`dog_controller_no_cpg.py` (MIT, Copyright (c) 2026 YueWang996): their logic, re-expressed here.

Each foot follows, relative to its hip, a stride x = L s cos(phi) (L: their `step_length`, s: the side's
steering scale) with a raised half z = H sin(phi) while sin(phi) > 0 and a flat half z = 0, `hip_depth_m`
below the hip; leg phases (0, 0, pi, pi) for HL, HR, FL, FR; joint targets by two-link IK, tracked by a joint
PD (8 N*m/rad, 0.1 N*m*s/rad, zero rate target). Speed is emergent.

`variant="authors"` (the default) runs it as their code does:
- their IK's x is a leg frame's, which is the robot's -x (forward kinematics on their MJCF): the raised
  arc moves the foot from back to front, so the robot-frame target is x = -L s cos(phi);
- steering once per cycle (at the phase wrap): cmd = kp e + kd (e - e_prev), e = -yaw, kp = -0.3,
  kd = -0.1, stride scales 1 - cmd (left) and 1 + cmd (right), cmd clipped to +-0.4;
- control runs when >= 5 ms have elapsed since the last call on a float clock (`ControlClock`: every 5 or
  6 steps at 1 ms, ~182 Hz), torques held between calls, zero until the first call at 5 ms;
- the start is on the trajectory at full amplitude at t = 0 (`start_leg_angles`, which a world applies
  with its start pose: on the spined dog the hind body at 0.24 m and spine q (-0.6, 1.2, -0.6), feet
  ~2 cm in the floor), the legs posed at the trot's phase offsets (`start_leg_offsets_rad`): their
  `main_robot.py` poses the legs from the generator before it switches it from its default trot to the
  bound, so the right legs start at the other end of their stride;
- frequency adaptation (`adapt_frequency`): at each call the spine x is low-passed at 6 Hz (filter step
  5 ms); a local maximum above 0.02 m is a peak, and the gait phase at the peak's time is recorded while
  2 s < t < 4 s; at the first peak after 4 s their circular mean becomes the target; later, a lag above
  0.1 rad lowers f by 1 Hz/rad, smoothed 1:1 with the present f, clipped to 2.8-3.2 Hz, applied at the
  next cycle start (phase kept continuous from the previous call's time).
The spine side of their run (the impedance schedule, same call clock) is `spine_drive.SpineSchedule`
with `authors_clock`.

`variant="literal"` is the first port to the Solo12 host, kept by name: x = `direction` * L s cos(phi)
read as the robot's x (with `direction` = +1 the raised arc runs front to back, the reverse of theirs),
yaw PD +0.3 / +0.1, the gait advanced every physics step, a stand of `start_s` then the stride amplitude
ramped from 0 to L over `ramp_s`, adaptation fed every step.

Hosts with hip abduction (Solo12) hold it at 0 with a PD (`haa_kp`, `haa_kd`); the authors' dog has none.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from sparc_quad.gaits.base import Gait
from sparc_quad.gaits.sine_kernel import foot_xz
from sparc_quad.sim.control_clock import ControlClock
from sparc_quad.sim.quadruped_world import planar_leg_ik

LEGS = ("HL", "HR", "FL", "FR")
PHASE_OFFSET = {"HL": 0.0, "HR": 0.0, "FL": math.pi, "FR": math.pi}
VARIANTS = ("authors", "literal")
TWO_PI = 2 * math.pi


@dataclass(frozen=True)
class SineBoundParams:
    frequency_hz: float = 3.1  # initial gait frequency
    step_length_m: float = 0.12  # L, their `step_length`: x = L cos(phi)
    step_height_m: float = 0.06  # H: swing clearance
    hip_depth_m: float = 0.23  # foot below the hip in stance
    kp_nm_rad: float = 8.0  # joint PD on HFE and KFE
    kd_nm_s_rad: float = 0.1
    haa_kp_nm_rad: float = 15.0  # abduction held at 0 (hosts that have it)
    haa_kd_nm_s_rad: float = 0.4
    variant: str = "authors"  # authors | literal (see the module docstring)
    yaw_kp: float | None = None  # steering gains; None: the variant's (authors -0.3/-0.1, literal +0.3/+0.1)
    yaw_kd: float | None = None
    control_period_s: float = 0.005  # authors: the controller's call period (ControlClock rule)
    adapt_frequency: bool = False  # the authors' phase-of-peak-extension frequency adaptation
    adapt_gain_hz_rad: float = 1.0
    adapt_min_hz: float = 2.8
    adapt_max_hz: float = 3.2
    adapt_calibrate_from_s: float = 2.0
    adapt_switch_s: float = 4.0  # calibration ends, adaptation starts (the spine switch time)
    adapt_filter_hz: float = 6.0
    adapt_min_peak_m: float = 0.02  # authors: peaks of the filtered spine x below this are ignored
    direction: float = 1.0  # literal: +1 the authors' x read as the robot's, -1 reversed
    start_phase_rad: float = 0.0  # gait clock at the start of stepping (study seeds vary it)
    # authors: leg phase offsets (rad; HL, HR, FL, FR) of the start pose only. Their main_robot.py calls
    # get_joint_angles(0.0) to pose the legs while the DogController's generator is still its default
    # trot, and only then set_gait_type('bound'): the legs start at the trot's (0, pi, pi, 0), then step
    # with the bound's (0, 0, pi, pi). Copyright (c) 2026 YueWang996 (MIT).
    start_leg_offsets_rad: tuple[float, float, float, float] = (0.0, math.pi, math.pi, 0.0)
    start_spine_q_rad: tuple[float, float, float] | None = None  # authors: spine at t = 0 (None: the arch)
    start_base_height_m: float | None = None  # authors: hind-body frame height at t = 0 (None: the stand's)
    start_s: float = 0.3  # literal only: stand, then ramp
    ramp_s: float = 1.0
    speed_m_s: float = 0.0  # not a target (speed is emergent); kept for the metrics' window logic
    accel_m_s2: float = 0.0

    @property
    def authors(self) -> bool:
        return self.variant == "authors"

    @property
    def steering_gains(self) -> tuple[float, float]:
        kp = self.yaw_kp if self.yaw_kp is not None else (-0.3 if self.authors else 0.3)
        kd = self.yaw_kd if self.yaw_kd is not None else (-0.1 if self.authors else 0.1)
        return kp, kd

    @property
    def running_from_s(self) -> float:
        """When the full-amplitude gait runs: at once for the authors' start, after stand and ramp else."""
        return 0.0 if self.authors else self.start_s + self.ramp_s

    def validate(self, reach_m: float = 0.32) -> None:
        if self.variant not in VARIANTS:
            raise ValueError(f"sine bound variant must be one of {', '.join(VARIANTS)}, got {self.variant!r}")
        if self.direction not in (1.0, -1.0):
            raise ValueError(f"direction must be +1 or -1, got {self.direction}")
        if not (0.0 < self.frequency_hz <= 10.0):
            raise ValueError(f"frequency must be in (0, 10] Hz, got {self.frequency_hz}")
        if self.step_length_m < 0 or self.step_height_m < 0 or self.hip_depth_m <= self.step_height_m:
            raise ValueError("step length and height must be >= 0 and the hip depth above the step height")
        if not self.control_period_s > 0:
            raise ValueError(f"control period must be > 0 s, got {self.control_period_s}")
        reach = math.hypot(self.step_length_m * 1.4, self.hip_depth_m)  # +40 % steering stride
        if reach >= reach_m:
            raise ValueError(f"foot target {reach:.3f} m from the hip is beyond the {reach_m:.3f} m leg")


class SineBoundController(Gait):
    """Leg torques of the open-loop bound. `step(t)` -> {leg: (tau_haa, tau_hfe, tau_kfe)} N*m, once per
    physics step; `observe_spine(t, x)` after it with the spine extension (m) the spine drive computed."""

    def __init__(self, world, params: SineBoundParams | None = None, backend: str = "python"):
        """`backend` "numba": the joint PD at each call through the compiled `sine_kernel.pd_step` (the same
        doubles as the Python path, tests/sparc_quad/gaits/test_sine_kernel.py)."""
        self.p = p = params or SineBoundParams()
        legs = world.meta["legs"]
        reach = min(legs[k]["thigh_m"] + legs[k]["shank_m"] for k in LEGS)
        p.validate(reach)
        self.w = world
        self.dt = world.cfg.dt_s
        self.tau_limit = float(world.meta["leg_torque_limit_nm"])
        self._x_sign = -1.0 if p.authors else p.direction  # the stride's sign in the robot's x
        # per leg: its phase offset, side, joint slots in the world's jq / jdq, and IK constants
        self._legs = tuple((k, PHASE_OFFSET[k], k[1], world.leg_joint_slots(k), world.leg_links(k))
                           for k in LEGS)
        self.frequency_hz = p.frequency_hz
        self.stride_scale = {"L": 1.0, "R": 1.0}
        self._kp_yaw, self._kd_yaw = p.steering_gains
        self._last_yaw_err = 0.0
        self._pending_f: float | None = None
        self.out = {k: (0.0, 0.0, 0.0) for k in LEGS}
        self._compiled = None
        if backend == "numba":
            from sparc_quad.gaits.sine_compiled import pd_step

            self._compiled = pd_step
            self._legs_arr = np.array([[off, 1.0 if side == "R" else 0.0, *slots, *links]
                                       for _, off, side, slots, links in self._legs], dtype=float)
            self._gains_arr = np.array([p.kp_nm_rad, p.kd_nm_s_rad, p.haa_kp_nm_rad, p.haa_kd_nm_s_rad,
                                        self.tau_limit, self._x_sign, p.step_length_m, p.hip_depth_m,
                                        p.step_height_m], dtype=float)
            self._out_arr = np.zeros((4, 3))
            self.backend = "numba"
        self.stance_flags = {"hind": True, "front": True}
        self.target_peak_phase: float | None = None
        self._cal_phases: list[float] = []
        self.cycle_starts = 0
        self.frequency_changes: list[tuple[float, float]] = []  # (t s, new f Hz)
        self._x_lp: float | None = None
        self._x_hist: list[float] = []
        self._t_hist: list[float] = []
        if p.authors:
            self.clock: ControlClock | None = ControlClock(p.control_period_s, self.dt)
            # phase(t) = omega t + offset (their generator); offset kept continuous across f changes
            self._offset = p.start_phase_rad
            self._last_phase = 0.0  # wrapped phase at the previous call (their wrap detectors start at 0)
            self._last_call_t = 0.0
            self._lp_a = p.control_period_s / (1.0 / (TWO_PI * p.adapt_filter_hz) + p.control_period_s)
            self.called = False
        else:
            self.clock = None
            self.phase = p.start_phase_rad  # gait clock, rad (unwrapped)
            self._lp_a = 1.0 - math.exp(-TWO_PI * p.adapt_filter_hz * self.dt)
            self._stand = {k: world.leg_ik(k, 0.0, -p.hip_depth_m) for k in LEGS}

    # ---- the gait clock ----------------------------------------------------------------------------
    def _phase_at(self, t: float) -> float:
        """Authors: the unwrapped gait phase at time t with the present frequency and offset."""
        return TWO_PI * self.frequency_hz * t + self._offset

    def _set_frequency(self, f_hz: float, t: float) -> None:
        phase = self._phase_at(t)
        self.frequency_hz = f_hz
        self._offset = phase - TWO_PI * f_hz * t

    @property
    def gait_phase(self) -> float:
        """Gait clock wrapped to [0, 2 pi)."""
        if self.clock is None:
            return self.phase % TWO_PI
        return self._phase_at(self.clock.now_s) % TWO_PI

    def phase_fraction(self) -> float:
        return self.gait_phase / TWO_PI

    def frequency(self) -> float:
        return self.frequency_hz

    # ---- targets -------------------------------------------------------------------------------------
    def foot_target(self, leg: str, phase: float, amp: float = 1.0) -> tuple[float, float]:
        """Foot (x forward, z up) relative to the hip in the body frame, m."""
        return self._foot_xz(phase + PHASE_OFFSET[leg], self.stride_scale[leg[1]], amp)

    def _foot_xz(self, ph: float, scale: float, amp: float) -> tuple[float, float]:
        """`foot_target` at the leg's own phase `ph` (rad) and its side's stride scale."""
        p = self.p
        return foot_xz(ph, scale, amp, self._x_sign, p.step_length_m, p.hip_depth_m, p.step_height_m)

    def start_leg_angles(self) -> dict[str, tuple[float, float]]:
        """(HFE, KFE) of each leg at the start: on the trajectory at t = 0 at the start offsets (authors:
        the trot's, as their code poses it), standing (literal)."""
        p = self.p
        if not p.authors:
            return dict(self._stand)
        g = self._phase_at(0.0)
        return {k: self.w.leg_ik(k, *self._foot_xz(g + off, self.stride_scale[k[1]], 1.0))
                for k, off in zip(LEGS, p.start_leg_offsets_rad, strict=True)}

    def start_pose(self):
        """(spine q or None, leg angles, base height or None) for `world.set_start`; None: the stand."""
        p = self.p
        if not p.authors:
            return None
        return p.start_spine_q_rad, self.start_leg_angles(), p.start_base_height_m

    def _steer(self) -> None:
        err = -self.w.yaw  # heading target 0
        cmd = self._kp_yaw * err + self._kd_yaw * (err - self._last_yaw_err)
        self._last_yaw_err = err
        cmd = max(-0.4, min(0.4, cmd))
        self.stride_scale = {"L": 1.0 - cmd, "R": 1.0 + cmd}  # cmd > 0: right strides longer

    def _pd(self, phase: float, amp: float, running: bool) -> None:
        if running and self._compiled is not None:
            self._pd_compiled(phase, amp)
            return
        p, w, lim = self.p, self.w, self.tau_limit
        jq, jdq, scale, out = w.jq, w.jdq, self.stride_scale, self.out
        kp, kd, haa_kp, haa_kd = p.kp_nm_rad, p.kd_nm_s_rad, p.haa_kp_nm_rad, p.haa_kd_nm_s_rad
        for leg, offset, side, (i_haa, i_hfe, i_kfe), links in self._legs:  # world.leg_state's values
            if running:
                h_d, k_d = planar_leg_ik(*links, *self._foot_xz(phase + offset, scale[side], amp))
            else:
                h_d, k_d = self._stand[leg]
            tau_haa = -haa_kp * jq[i_haa] - haa_kd * jdq[i_haa]
            tau_h = kp * (h_d - jq[i_hfe]) - kd * jdq[i_hfe]
            tau_k = kp * (k_d - jq[i_kfe]) - kd * jdq[i_kfe]
            out[leg] = (max(-lim, min(lim, tau_haa)), max(-lim, min(lim, tau_h)), max(-lim, min(lim, tau_k)))
        self.stance_flags["hind"] = not running or math.sin(phase) <= 0.0
        self.stance_flags["front"] = not running or math.sin(phase + math.pi) <= 0.0

    def _pd_compiled(self, phase: float, amp: float) -> None:
        w, scale, out, arr = self.w, self.stride_scale, self.out, self._out_arr
        self._compiled(phase, amp, scale["L"], scale["R"], np.array(w.jq, dtype=float),
                       np.array(w.jdq, dtype=float), self._legs_arr, self._gains_arr, arr)
        hl, hr, fl, fr = arr.tolist()
        out["HL"], out["HR"], out["FL"], out["FR"] = tuple(hl), tuple(hr), tuple(fl), tuple(fr)
        self.stance_flags["hind"] = math.sin(phase) <= 0.0
        self.stance_flags["front"] = math.sin(phase + math.pi) <= 0.0

    def step(self, t: float) -> dict[str, tuple[float, float, float]]:
        if self.clock is None:
            return self._step_literal(t)
        if not self.clock.tick():
            return self.out  # held between calls (zero before the first)
        t = self.clock.now_s
        self.called = True
        now = self._phase_at(t) % TWO_PI
        if now < self._last_phase:  # a new cycle: the queued frequency, then the steering
            self.cycle_starts += 1
            if self._pending_f is not None:
                self._set_frequency(self._pending_f, self._last_call_t)
                self.frequency_changes.append((t, self._pending_f))
                self._pending_f = None
            now = self._phase_at(t) % TWO_PI
            if now < self._last_phase:
                self._steer()
        self._last_phase = now
        self._last_call_t = t
        self._pd(self._phase_at(t), 1.0, True)
        return self.out

    def _step_literal(self, t: float) -> dict[str, tuple[float, float, float]]:
        p = self.p
        running = t >= p.start_s
        amp = min(1.0, (t - p.start_s) / p.ramp_s) if running and p.ramp_s > 0 else float(running)
        if running:
            before = self.phase
            self.phase += TWO_PI * self.frequency_hz * self.dt
            if math.floor(self.phase / TWO_PI) != math.floor(before / TWO_PI):
                self.cycle_starts += 1
                if self._pending_f is not None:
                    self.frequency_hz, self._pending_f = self._pending_f, None
                    self.frequency_changes.append((t, self.frequency_hz))
                self._steer()
        self._pd(self.phase, amp, running)
        return self.out

    # ---- frequency adaptation ----------------------------------------------------------------------
    def observe_spine(self, t: float, spine_x_m: float) -> None:
        """Feed the spine extension x (m) after each `step`: the frequency adaptation's peak detector
        (authors: only at control calls, with that call's time and a 200-sample history)."""
        p = self.p
        if not p.adapt_frequency:
            return
        if self.clock is not None:
            if not (self.called and self.clock.last_call_s == self.clock.now_s):
                return
            t = self.clock.now_s
        self._x_lp = spine_x_m if self._x_lp is None else (
            self._lp_a * spine_x_m + (1.0 - self._lp_a) * self._x_lp)
        h, th = self._x_hist, self._t_hist
        h.append(self._x_lp)
        th.append(t)
        if len(h) > 200:
            del h[0], th[0]
        if len(h) <= 5 if self.clock is not None else len(h) < 3:
            return
        if not (h[-2] > h[-1] and h[-2] > h[-3]):
            return
        if self.clock is not None:
            if h[-2] <= p.adapt_min_peak_m:
                return
            phase_at_peak = self._phase_at(th[-2]) % TWO_PI
        else:
            phase_at_peak = (self.phase - TWO_PI * self.frequency_hz * self.dt) % TWO_PI
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
        lag = (phase_at_peak - self.target_peak_phase + math.pi) % TWO_PI - math.pi
        if lag > 0.1:
            f_new = min(p.adapt_max_hz, max(p.adapt_min_hz, self.frequency_hz - p.adapt_gain_hz_rad * lag))
            f_s = 0.5 * f_new + 0.5 * self.frequency_hz
            if abs(f_s - self.frequency_hz) > 0.01:
                self._pending_f = f_s
