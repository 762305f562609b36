"""A clock-driven bound for the spined quadruped: Raibert-style virtual-leg control.

The controller (sagittal plane; left and right legs of a pair act as one virtual leg, Raibert 1986,
"Legged Robots That Balance", ch. 6 and Raibert, Chepponis & Brown 1986, "Running on four legs as
though they were one") does three things per pair (hind legs on the hind body, front legs on the
front body):

- Stance: a prescribed vertical force profile (half sine) whose impulse over the stance carries the pair's
  share of the weight for a whole stride, as in the impulse-planning bound of the MIT Cheetah 2 (Park,
  Wensing & Kim 2017, IJRR 36(2)); plus height feedback, a horizontal force that servoes forward speed,
  and a hip torque that servoes the pitch of that pair's body (Raibert's attitude servo in stance).
  Forces become joint torques through the leg Jacobian transpose.
- Flight: the foot follows a swing curve (cycloid in x, half-sine lift of `step_height`) to Raibert's
  touchdown point x_td = v T_stance / 2 + k_v (v - v_d) ahead of the hip, by a Cartesian PD.
- Roll and yaw are held by left/right differences of the stance forces; lateral drift steers yaw.

The gait clock fixes the timing: hind stance in phase [0, D), front stance in [phi, phi + D).
All gains are per unit mass of the pair so the controller scales with the host.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import ClassVar

from sparc_quad.gaits.base import Gait
from sparc_quad.gaits.bound_kernel import leg_fk
from spine_module import params as P


@dataclass(frozen=True)
class BoundParams:
    frequency_hz: float = 4.0  # stride frequency
    duty: float | None = None  # stance fraction of each pair; None: scheduled on speed (below)
    duty_slow: float = 0.5  # duty at and below `duty_speeds[0]`
    duty_fast: float = 0.45  # duty at and above `duty_speeds[1]` (duty falls with speed, as in animals)
    duty_speeds: tuple[float, float] = (0.3, 0.6)  # m/s
    phase_offset: float = 0.5  # front stance starts this fraction of a stride after the hind
    speed_m_s: float = 0.6  # target forward speed (stride length = speed / frequency)
    step_height_m: float = 0.07
    height_m: float = 0.22  # hip height above the ground (foot centre), target
    raibert_gain_s: float = 0.1  # k_v of the touchdown law, s
    speed_ki: float = 1.0  # integral gain on the speed error (offsets the commanded speed), 1/s
    speed_int_max: float = 0.6  # m/s
    speed_gain: float = 15.0  # stance horizontal force per unit mass per (m/s) of speed error, 1/s
    height_kp: float = 600.0  # stance tracking of the hip-height reference, per unit mass, 1/s^2
    height_kd: float = 30.0  # 1/s
    pitch_kp: float = 0.0  # pitch moment per rad of the hip line's pitch, N*m/rad (via stance forces)
    pitch_kd: float = 0.0
    body_kp: float = 6.0  # stance hip torque per rad of body pitch relative to the hip line, N*m/rad
    body_kd: float = 0.6  # N*m*s/rad
    roll_kp: float = 80.0  # left/right force difference per rad of roll, N/rad
    roll_kd: float = 4.0
    yaw_kp: float = 40.0
    yaw_kd: float = 2.0
    lateral_gain: float = 1.0  # yaw target per metre of lateral drift, rad/m
    swing_kp: float = 600.0  # N/m
    swing_kd: float = 12.0  # N*s/m
    abduction_kp: float = 15.0  # N*m/rad, holds HAA at 0
    abduction_kd: float = 0.4
    friction_use: float = 0.6  # horizontal/vertical stance force ratio allowed
    start_s: float = 0.3  # stand still this long before the first stride
    accel_m_s2: float = 0.5  # target speed ramps up at this rate
    yaw_target_max_rad: float = 0.2  # the lateral-drift yaw target is clipped to +-this
    touchdown_max_m: float = 0.12  # Raibert touchdown point clipped to +-this fore-aft of the hip
    pitch_arm_min_m: float = 0.02  # no pitch force from a pair whose moment arm about the COM is shorter
    touchdown_sink_m: float = 0.01  # the swing ends this far below the ground, so the foot lands
    stand_damping_1_s: float = 2.0  # before the start: horizontal stance force -m * this * vx, 1/s

    def duty_at(self, speed_m_s: float) -> float:
        if self.duty is not None:
            return self.duty
        lo, hi = self.duty_speeds
        f = min(1.0, max(0.0, (abs(speed_m_s) - lo) / (hi - lo))) if hi > lo else 1.0
        return self.duty_slow + f * (self.duty_fast - self.duty_slow)

    def with_stride(self, stride_m: float) -> BoundParams:
        """Same gait, target speed set from a stride length at the current frequency."""
        return replace(self, speed_m_s=stride_m * self.frequency_hz)


class _Lowpass:
    __slots__ = ("a", "y")

    def __init__(self, cutoff_hz: float, dt: float, y0: float = 0.0):
        self.a = 1.0 - math.exp(-2 * math.pi * cutoff_hz * dt)
        self.y = y0

    def __call__(self, x: float) -> float:
        self.y += self.a * (x - self.y)
        return self.y


class BoundController(Gait):
    """Leg torques for the bound. `step(world, t)` -> {leg: (tau_haa, tau_hfe, tau_kfe)}."""

    PAIRS: ClassVar[dict[str, tuple[str, str]]] = {"hind": ("HL", "HR"), "front": ("FL", "FR")}

    def __init__(self, world, params: BoundParams | None = None):
        self.p = params or BoundParams()
        self.w = world
        meta = world.meta
        self.legs = meta["legs"]
        dt = world.cfg.dt_s
        self.dt = dt
        self.slope = world.cfg.slope_rad
        self.mass = world.total_mass
        share_front = world.front_weight_share()
        self.share = {"front": share_front, "hind": 1.0 - share_front}
        self.tau_limit = float(meta["leg_torque_limit_nm"])
        self.lx = {k: v["hip_x_m"] for k, v in self.legs.items()}
        self.speed_f = _Lowpass(4.0, dt)
        self._prev_hip: dict[str, tuple[float, float] | None] = {"hind": None, "front": None}
        self.hip_vel = {"hind": _Lowpass(40.0, dt), "front": _Lowpass(40.0, dt)}
        self.hip_vz = {"hind": _Lowpass(40.0, dt), "front": _Lowpass(40.0, dt)}
        self.liftoff: dict[str, tuple[float, float] | None] = dict.fromkeys(self.legs)
        self.in_stance = dict.fromkeys(self.legs, True)
        self.v_target = 0.0
        self.v_int = 0.0
        self.duty = self.p.duty_at(0.0)
        self.phase = 0.0
        self.out = {k: (0.0, 0.0, 0.0) for k in self.legs}
        self.stance_flags = dict.fromkeys(self.PAIRS, True)

    # -- helpers -------------------------------------------------------------------------------------
    def _pair_body(self, pair: str):
        """(origin x, origin z, pitch, pitch rate) of the pair's body frame in the world's x-z plane."""
        w = self.w
        x, _, z = w.base_pos
        phi, dphi = w.q1, w.dq1
        if pair == "hind":
            return x, z, phi, dphi
        links = P.DEFAULT_SPINE.links
        for q, dq, link in zip(w.q_spine, w.dq_spine, links[:3], strict=True):
            x += link.length_m * math.cos(phi)
            z -= link.length_m * math.sin(phi)
            phi += q
            dphi += dq
        return x, z, phi, dphi

    def phase_fraction(self) -> float:
        return self.phase

    def frequency(self) -> float:
        return self.p.frequency_hz

    def _stance_window(self, pair: str, phase: float) -> float | None:
        """Fraction of the stance elapsed, or None in flight."""
        start = 0.0 if pair == "hind" else self.p.phase_offset
        s = (phase - start) % 1.0
        return s / self.duty if s < self.duty else None

    def stance_reference(self, frac: float) -> tuple[float, float, float]:
        """Hip height, its rate and acceleration (net of gravity) over a stance, fraction `frac` elapsed.

        The vertical force is a half sine whose impulse carries the pair's weight for a whole stride; the
        hip touches down at `height_m` falling at g t_flight / 2 and leaves rising at the same speed, so
        the flight between is the ballistic arc of a periodic bound (impulse planning, Park et al. 2017).
        """
        p = self.p
        g = P.GRAVITY_M_S2
        period = 1.0 / p.frequency_hz
        ts = self.duty * period
        tf = period - ts
        a = math.pi * g * period / (2.0 * ts)
        tau = frac * ts
        sn, cs = math.sin(math.pi * frac), math.cos(math.pi * frac)
        v0 = -0.5 * g * tf
        k = a * ts / math.pi
        z = p.height_m + v0 * tau + k * (tau - ts / math.pi * sn) - 0.5 * g * tau * tau
        dz = v0 + k * (1.0 - cs) - g * tau
        return z, dz, a * sn - g

    # -- control -------------------------------------------------------------------------------------
    def step(self, t: float) -> dict[str, tuple[float, float, float]]:
        p, w = self.p, self.w
        g = P.GRAVITY_M_S2
        tan_s = math.tan(self.slope)
        running = t >= p.start_s
        if running:
            self.v_target = (
                min(p.speed_m_s, self.v_target + p.accel_m_s2 * self.dt)
                if p.speed_m_s >= 0
                else max(p.speed_m_s, self.v_target - p.accel_m_s2 * self.dt)
            )
            self.phase = ((t - p.start_s) * p.frequency_hz) % 1.0
        v_d = self.v_target
        self.duty = p.duty_at(self.v_target)
        period = 1.0 / p.frequency_hz
        t_stance = self.duty * period
        roll, yaw = w.roll, w.yaw
        wx, _, wz = w.base_omega
        yaw_d = -p.lateral_gain * w.base_pos[1]
        yaw_d = max(-p.yaw_target_max_rad, min(p.yaw_target_max_rad, yaw_d))
        d_roll = p.roll_kp * roll + p.roll_kd * wx
        d_yaw = p.yaw_kp * (yaw - yaw_d) + p.yaw_kd * wz
        kin = {}
        body = {}
        for pair, (left, _) in self.PAIRS.items():
            bx, bz, phi, dphi = self._pair_body(pair)
            c, s = math.cos(phi), math.sin(phi)
            hip_bx = self.lx[left]
            hx = bx + c * hip_bx
            hz = bz - s * hip_bx
            prev = self._prev_hip[pair] or (hx, hz)
            vx = self.hip_vel[pair]((hx - prev[0]) / self.dt)
            vz = self.hip_vz[pair]((hz - prev[1]) / self.dt)
            self._prev_hip[pair] = (hx, hz)
            kin[pair] = (c, s, hx, hz, vx, vz)
            body[pair] = (phi, dphi)
        # attitude of the whole robot: the line through the hind and front hips
        _, _, hx_h, hz_h, vx_h, vz_h = kin["hind"]
        _, _, hx_f, hz_f, vx_f, vz_f = kin["front"]
        span = math.hypot(hx_f - hx_h, hz_f - hz_h)
        pitch = -math.atan2(hz_f - hz_h, hx_f - hx_h)
        dpitch = -((vz_f - vz_h) * (hx_f - hx_h) - (vx_f - vx_h) * (hz_f - hz_h)) / (span * span)
        self.pitch = pitch
        # desired pitch moment on the robot (about +y, nose down positive), made by the stance forces
        tau_pitch = -(p.pitch_kp * (pitch + self.slope) + p.pitch_kd * dpitch)
        com_x = hx_h + self.share["front"] * (hx_f - hx_h)
        v_mean = 0.5 * (vx_h + vx_f)
        v_avg = self.speed_f(v_mean)
        if running and p.speed_ki > 0.0:  # integral action on the stride-averaged speed
            self.v_int += p.speed_ki * (self.v_target - v_avg) * self.dt
            self.v_int = max(-p.speed_int_max, min(p.speed_int_max, self.v_int))
        v_d = self.v_target + self.v_int
        for pair, (left, right) in self.PAIRS.items():
            c, s, hx, hz, vx, vz = kin[pair]
            height = hz - hx * tan_s  # above the ground along gravity
            m_pair = self.share[pair] * self.mass
            frac = self._stance_window(pair, self.phase) if running else 0.5
            stance = frac is not None
            self.stance_flags[pair] = stance
            r_x = hx - com_x  # moment arm of this pair's vertical force about the COM
            dfz_pitch = -tau_pitch / r_x if abs(r_x) > p.pitch_arm_min_m else 0.0
            for leg in (left, right):
                st = w.leg_state(leg)
                meta = self.legs[leg]
                l1, l2 = meta["thigh_m"], meta["shank_m"]
                fx_b, fz_b, fvx_b, fvz_b, j11, j12, j21, j22 = leg_fk(l1, l2, st.hfe, st.kfe, st.dhfe,
                                                                      st.dkfe)
                side = 1.0 if leg[1] == "L" else -1.0
                tau_haa = -p.abduction_kp * st.haa - p.abduction_kd * st.dhaa
                if stance:
                    if running:
                        z_d, dz_d, a_d = self.stance_reference(frac)
                    else:
                        z_d, dz_d, a_d = p.height_m, 0.0, 0.0
                    fz = m_pair * (g + a_d + p.height_kp * (z_d - height) + p.height_kd * (dz_d - vz))
                    fz += dfz_pitch
                    fz = max(0.0, 0.5 * fz - side * 0.5 * d_roll)
                    if running:
                        fx = 0.5 * m_pair * p.speed_gain * (v_d - vx)
                    else:
                        fx = -0.5 * m_pair * p.stand_damping_1_s * vx
                    fx += side * 0.5 * d_yaw * (fz > 0.0)
                    lim = p.friction_use * fz
                    fx = max(-lim, min(lim, fx))
                    # ground reaction (fx, fz) in world; the foot pushes with the opposite force.
                    ex = -(c * fx - s * fz)
                    ez = -(s * fx + c * fz)
                    tau_h = j11 * ex + j21 * ez
                    tau_k = j12 * ex + j22 * ez
                    # Raibert's stance attitude servo, per body: the hip torque's reaction turns the body
                    # toward the hip line's pitch (the bound's own pitching is left alone).
                    phi_b, dphi_b = body[pair]
                    tau_h += 0.5 * (p.body_kp * (phi_b - pitch) + p.body_kd * (dphi_b - dpitch))
                    self.liftoff[leg] = None
                else:
                    # foot target relative to the hip, world-aligned axes
                    sw = (self.phase - (0.0 if pair == "hind" else p.phase_offset) - self.duty) % 1.0
                    sw_frac = min(1.0, sw / (1.0 - self.duty))
                    if self.liftoff[leg] is None:
                        self.liftoff[leg] = (c * fx_b + s * fz_b, -s * fx_b + c * fz_b)
                    x_lo, z_lo = self.liftoff[leg]
                    x_td = vx * t_stance / 2.0 + p.raibert_gain_s * (vx - self.v_target)
                    x_td = max(-p.touchdown_max_m, min(p.touchdown_max_m, x_td))
                    blend = 0.5 * (1.0 - math.cos(math.pi * sw_frac))
                    tx = x_lo + (x_td - x_lo) * blend
                    # clearance above the ground under the target, measured from the actual hip height
                    lo_clear = z_lo + height - x_lo * tan_s
                    clear = (
                        lo_clear * (1.0 - sw_frac)
                        + p.step_height_m * math.sin(math.pi * sw_frac)
                        - p.touchdown_sink_m * sw_frac
                    )
                    tz = -height + tx * tan_s + clear
                    # to the body frame
                    tbx = c * tx - s * tz
                    tbz = s * tx + c * tz
                    ex = p.swing_kp * (tbx - fx_b) - p.swing_kd * fvx_b
                    ez = p.swing_kp * (tbz - fz_b) - p.swing_kd * fvz_b
                    tau_h = j11 * ex + j21 * ez
                    tau_k = j12 * ex + j22 * ez
                lim = self.tau_limit
                self.out[leg] = (
                    max(-lim, min(lim, tau_haa)),
                    max(-lim, min(lim, tau_h)),
                    max(-lim, min(lim, tau_k)),
                )
        return self.out
