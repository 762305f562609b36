"""Gait C: the SPARC authors' speed-commanded Raibert bound for their spined dog.

Source: github.com/YueWang996/sparc, commit 9aee563d6d07dffe7dd121e0d931e959667e18a7,
`mujoco_simulation/dog_controller_raibert.py` and `main_robot_raibert.py` (MIT, Copyright (c) 2026
YueWang996): their logic, re-expressed here; no line of theirs is copied.

A fixed gait clock at `frequency_hz` (3.1 Hz) with leg phases (0, 0, pi, pi) for HL, HR, FL, FR; a leg swings
while sin(phase) > 0 and stands otherwise. In their leg frame (x = the robot's -x, z up, hip angle
q_math = q_robot - pi/2):
- swing: from lift-off x_lo = -x_td(previous) to touchdown x_td = 0.5 T_stance v_cmd + k (v - v_cmd) (k 0.08
  hind, 0.12 front, clipped to +-0.2 m; a front leg's x_td negated) along a cosine in x and a sine arch of
  `step_height_m` in z, `standing_height` -0.23 m below the hip; two-link IK (0.151 m links), joint PD 10
  N*m/rad, 0.1 N*m*s/rad;
- stance: tau = J^T (Fx, Fz) with Fz -25 N plus a height PD (80/4 hind, 80/10 front, target 0.23 m on a
  low-passed height), a pitch PD on the front legs (+) and hind legs (-) (50/5, target -0.1 rad), a roll PI
  (30/0.1, left -, right +), Fz clipped to [-80, -2] N; Fx 10 N (hind) plus a speed PI (40, 0.1) on the
  hind legs and -20 (v_cmd - v) on the front, a yaw PI (20/0.05) differential on the hind legs, Fx clipped
  to [-20, 40] N;
- speed: v of each body pair is the body-frame x of MuJoCo's `cvel` linear part (the velocity of the point
  at the whole robot's centre of mass moving with that body), averaged over the pair's last stance (their
  initial average is 1.0 m/s); the command ramps from 0.3 m/s at 1 m/s^2;
- calls: when >= 2 ms have elapsed on MuJoCo's float clock (`ControlClock`: every 2 or 3 steps at 1 ms,
  ~408 Hz), torques held between calls and zero before the first, the body state read as MuJoCo's `xpos`,
  `xmat` and `cvel` hold it after `mj_step` (one step old; `QuadWorld.authors_body_states`).

What looks wrong in their code is kept, and stated here:
- the IK's reference branch is the nominal pose plus pi/2 (their robot-to-math conversion is minus pi/2,
  as their Jacobian uses): it still selects the knee-back branch for the nominal targets, and an
  unreachable target (farther than 0.302 m from the hip) returns that reference, so the hip is then
  commanded pi away from nominal;
- the height loop's D term adds the vertical velocity (`-(kp e - kd vz)`), a positive feedback on vz;
- `dt` for the PI integrators is the time since the previous call (2 or 3 ms); the pitch rate is the
  difference of two pitches one call apart, low-passed 1:1;
- the stance-average selection keeps the last stance average whenever it is non-zero, so the filtered
  velocity is never used.
The torques are clipped to the world's leg motor limit (`WorldConfig.leg_torque_limit_nm`): their later
model allows +-120 N*m (the scenario's default for this gait), their earlier one (the one `robots/spined_dog`
is built from) +-12, at which their controller saturates and, in pybullet, runs backwards at 0.9 m/s.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from sparc_quad.gaits.base import Gait
from sparc_quad.sim.control_clock import ControlClock

LEGS = ("HL", "HR", "FL", "FR")
PHASE_OFFSET = (0.0, 0.0, math.pi, math.pi)  # their 'bound'
NOMINAL_Q = ((-0.785398, 1.5708), (-0.785398, 1.5708), (0.785398, -1.5708), (0.785398, -1.5708))
START_LEG_Q = {"HL": (-0.79, 1.57), "HR": (-0.79, 1.57), "FL": (0.79, -1.57), "FR": (0.79, -1.57)}
START_SPINE_Q_RAD = (-0.6, 1.2, -0.6)  # main_robot_raibert.py
START_BASE_HEIGHT_M = 0.25  # their model at 1c8013a: hind_body at 0.25 m
LOCKED_SPINE_Q_RAD = (-0.85, 1.5, -0.85)  # their locked-spine model (spined_dog_locked_spine.xml, 1c8013a)
TWO_PI = 2.0 * math.pi
HALF_PI = 0.5 * math.pi


@dataclass(frozen=True)
class AuthorsRaibertParams:
    speed_m_s: float = 1.3  # their script's command
    frequency_hz: float = 3.1
    step_height_m: float = 0.08
    control_period_s: float = 0.002  # their CONTROL_FREQ 500 Hz, on the float-clock rule
    start_phase_rad: float = 0.0  # their global_phase_offset (study seeds vary it)
    start_spine_q_rad: tuple[float, float, float] = START_SPINE_Q_RAD
    start_base_height_m: float = START_BASE_HEIGHT_M
    # their constants (dog_controller_raibert.py), named
    thigh_m: float = 0.151
    shank_m: float = 0.151
    standing_height_m: float = -0.23
    raibert_gain_hind_s: float = 0.08
    raibert_gain_front_s: float = 0.12
    feedforward_gain: float = 0.5
    max_stride_m: float = 0.2
    swing_kp: float = 10.0
    swing_kd: float = 0.1
    fz_n: float = -25.0
    fx_hind_n: float = 10.0
    target_pitch_rad: float = -0.1
    kp_pitch: float = 50.0
    kd_pitch: float = 5.0
    kp_vel: float = 40.0
    ki_vel: float = 0.1
    front_vel_gain: float = 20.0
    v_cmd_start_m_s: float = 0.3
    accel_m_s2: float = 1.0
    desired_height_m: float = 0.23
    height_filter_start_m: float = 0.25
    hind_kp_z: float = 80.0
    hind_kd_z: float = 4.0
    front_kp_z: float = 80.0
    front_kd_z: float = 10.0
    kp_roll: float = 30.0
    ki_roll: float = 0.1
    kp_yaw: float = 20.0
    ki_yaw: float = 0.05

    @property
    def running_from_s(self) -> float:
        """When the speed command has ramped from its start value to the target."""
        return abs(self.speed_m_s - self.v_cmd_start_m_s) / self.accel_m_s2

    def validate(self, reach_m: float = 0.302) -> None:
        if not (0.0 < self.frequency_hz <= 10.0):
            raise ValueError(f"frequency must be in (0, 10] Hz, got {self.frequency_hz}")
        if not (0.0 <= self.step_height_m < -self.standing_height_m):
            raise ValueError(f"step height must be in [0, {-self.standing_height_m}) m, "
                             f"got {self.step_height_m}")
        if not self.control_period_s > 0:
            raise ValueError(f"control period must be > 0 s, got {self.control_period_s}")
        if abs(self.thigh_m + self.shank_m - reach_m) > 0.01:
            raise ValueError(f"gait C is the spined dog's (0.151 m + 0.151 m legs); this robot's legs reach "
                             f"{reach_m:.3f} m")


def _rpy(r: tuple[float, ...]) -> tuple[float, float, float]:
    """Roll, pitch, yaw (ZYX) of a row-major rotation matrix, as their quaternion formula gives them."""
    roll = math.atan2(r[7], r[8])
    s = -r[6]
    pitch = math.copysign(HALF_PI, s) if abs(s) >= 1.0 else math.asin(s)
    yaw = math.atan2(r[3], r[0])
    return roll, pitch, yaw


def _body_x(r: tuple[float, ...], v: tuple[float, float, float]) -> float:
    """The body-frame x of a world-axes vector (R^T v)[0]."""
    return r[0] * v[0] + r[3] * v[1] + r[6] * v[2]


class AuthorsRaibertController(Gait):
    """Leg torques of gait C: `step(t)` -> {leg: (0, tau_hip, tau_knee)} N*m once per physics step."""

    def __init__(self, world, params: AuthorsRaibertParams | None = None):
        self.p = p = params or AuthorsRaibertParams()
        legs = world.meta["legs"]
        if any(legs[k]["haa"] is not None for k in LEGS):
            raise ValueError("gait C is the spined dog's: its legs have no abduction joint")
        p.validate(min(legs[k]["thigh_m"] + legs[k]["shank_m"] for k in LEGS))
        self.w = world
        self.tau_limit = world.leg_torque_limit_nm
        self.clock = ControlClock(p.control_period_s, world.cfg.dt_s)
        self._slots = tuple(world.leg_joint_slots(k)[1:] for k in LEGS)
        self.omega = TWO_PI * p.frequency_hz
        self.out = {k: (0.0, 0.0, 0.0) for k in LEGS}
        self.stance_flags = {"hind": True, "front": True}
        # their controller's state
        self.last_time = 0.0
        self.v_cmd = p.speed_m_s
        self.v_cmd_filtered = p.v_cmd_start_m_s
        self.vel_integral = 0.0
        self.filtered_height = p.height_filter_start_m
        self.roll_integral = 0.0
        self.yaw_integral = 0.0
        self.acc = [0.0, 0.0]  # hind, front: stance velocity sums
        self.count = [0, 0]
        self.stance_avg = [1.0, 1.0]
        self.last_in_stance = [False, False]
        self.filtered_v = [0.0, 0.0]
        self.filtered_pitch_rate = 0.0
        self.last_pitch = 0.0
        self.x_liftoff = [0.0] * 4
        self.x_touchdown = [0.0] * 4
        self.in_swing = [False] * 4

    # ---- Gait protocol ---------------------------------------------------------------------------------
    def phase(self, t: float) -> float:
        return (self.omega * t + self.p.start_phase_rad) % TWO_PI

    def phase_fraction(self) -> float:
        return self.phase(self.clock.now_s) / TWO_PI

    def frequency(self) -> float:
        return self.p.frequency_hz

    def start_pose(self):
        p = self.p
        return p.start_spine_q_rad, dict(START_LEG_Q), p.start_base_height_m

    def step(self, t: float) -> dict[str, tuple[float, float, float]]:
        if not self.clock.tick():
            return self.out  # held between calls (zero before the first)
        self._compute(self.clock.now_s)
        return self.out

    # ---- their controller --------------------------------------------------------------------------------
    def _compute(self, time: float) -> None:
        p, w = self.p, self.w
        dt = time - self.last_time
        if dt <= 0:
            dt = 0.001
        self.last_time = time
        hind_pos, hind_rot, hind_v, _hind_w, front_rot, front_v = w.authors_body_states()
        z_raw, vz = hind_pos[2], hind_v[2]
        roll, pitch, yaw = _rpy(hind_rot)
        self.filtered_height = 0.8 * self.filtered_height + 0.2 * z_raw
        phase = self.phase(time)
        v_local = (_body_x(hind_rot, hind_v), _body_x(front_rot, front_v))
        for pair, offset in ((0, PHASE_OFFSET[0]), (1, PHASE_OFFSET[2])):  # hind (leg 0), front (leg 2)
            stance = math.sin((phase + offset) % TWO_PI) <= 0.0
            if stance:
                self.acc[pair] += v_local[pair]
                self.count[pair] += 1
            if not stance and self.last_in_stance[pair]:
                if self.count[pair] > 0:
                    self.stance_avg[pair] = self.acc[pair] / self.count[pair]
                self.acc[pair], self.count[pair] = 0.0, 0
            self.last_in_stance[pair] = stance
            self.filtered_v[pair] = 0.5 * self.filtered_v[pair] + 0.5 * v_local[pair]
        v_final = [a if a != 0 else f for a, f in zip(self.stance_avg, self.filtered_v, strict=True)]
        pitch_rate = (pitch - self.last_pitch) / dt
        self.filtered_pitch_rate = 0.5 * self.filtered_pitch_rate + 0.5 * pitch_rate
        self.last_pitch = pitch
        limit = p.accel_m_s2 * dt
        self.v_cmd_filtered += max(-limit, min(limit, self.v_cmd - self.v_cmd_filtered))
        vel_error = self.v_cmd_filtered - v_final[0]
        self.vel_integral = max(-20.0, min(20.0, self.vel_integral + vel_error * dt))
        fx_vel = p.kp_vel * vel_error + p.ki_vel * self.vel_integral
        z_error = p.desired_height_m - self.filtered_height
        fz_height = (-(p.hind_kp_z * z_error - p.hind_kd_z * vz),
                     -(p.front_kp_z * z_error - p.front_kd_z * vz))
        fz_pitch = p.kp_pitch * (p.target_pitch_rad - pitch) - p.kd_pitch * self.filtered_pitch_rate
        self.roll_integral = max(-0.5, min(0.5, self.roll_integral - roll * dt))
        fz_roll = p.kp_roll * -roll + p.ki_roll * self.roll_integral
        yaw_error = -yaw
        if yaw_error > math.pi:
            yaw_error -= TWO_PI
        if yaw_error < -math.pi:
            yaw_error += TWO_PI
        self.yaw_integral = max(-0.5, min(0.5, self.yaw_integral + yaw_error * dt))
        fx_yaw = p.kp_yaw * yaw_error + p.ki_yaw * self.yaw_integral
        jq, jdq, lim = w.jq, w.jdq, self.tau_limit
        t_stance = 0.5 / p.frequency_hz
        for i, key in enumerate(LEGS):
            front, left = i >= 2, i % 2 == 0
            hip, knee = self._slots[i]
            q1, q2, v1, v2 = jq[hip], jq[knee], jdq[hip], jdq[knee]
            leg_phase = (phase + PHASE_OFFSET[i]) % TWO_PI
            swing = math.sin(leg_phase) > 0.0
            if swing and not self.in_swing[i]:  # lift-off: the next touchdown point
                self.x_liftoff[i] = -self.x_touchdown[i]
                gain = p.raibert_gain_front_s if front else p.raibert_gain_hind_s
                td = p.feedforward_gain * t_stance * self.v_cmd_filtered + gain * (
                    v_final[1 if front else 0] - self.v_cmd_filtered)
                td = max(-p.max_stride_m, min(p.max_stride_m, td))
                self.x_touchdown[i] = -td if front else td
            self.in_swing[i] = swing
            if swing:
                s = min(1.0, max(0.0, leg_phase / math.pi))
                alpha = 0.5 * (1.0 - math.cos(math.pi * s))
                x = self.x_liftoff[i] + alpha * (self.x_touchdown[i] - self.x_liftoff[i])
                z = p.step_height_m * math.sin(math.pi * s) + p.standing_height_m
                ref = (NOMINAL_Q[i][0] + HALF_PI, NOMINAL_Q[i][1])  # their reference (see the docstring)
                qd1, qd2 = self._ik(x, z, ref)
                qd1 += HALF_PI
                tau1 = p.swing_kp * (qd1 - q1) - p.swing_kd * v1
                tau2 = p.swing_kp * (qd2 - q2) - p.swing_kd * v2
            else:
                fx = 0.0 if front else p.fx_hind_n
                fz = p.fz_n
                if front:
                    fx -= p.front_vel_gain * vel_error
                    fz += fz_pitch
                else:
                    fx += fx_vel
                    fz -= fz_pitch
                fz += fz_height[1 if front else 0]
                fz += -fz_roll if left else fz_roll
                if not front:
                    fx += -fx_yaw if left else fx_yaw
                fz = max(-80.0, min(-2.0, fz))
                fx = max(-20.0, min(40.0, fx))
                a = q1 - HALF_PI
                s1, c1, s12, c12 = math.sin(a), math.cos(a), math.sin(a + q2), math.cos(a + q2)
                l1, l2 = p.thigh_m, p.shank_m
                # tau = J^T F, J = [[-l1 s1 - l2 s12, -l2 s12], [l1 c1 + l2 c12, l2 c12]]
                tau1 = (-l1 * s1 - l2 * s12) * fx + (l1 * c1 + l2 * c12) * fz
                tau2 = -l2 * s12 * fx + l2 * c12 * fz
            self.out[key] = (0.0, max(-lim, min(lim, tau1)), max(-lim, min(lim, tau2)))
        self.stance_flags["hind"] = math.sin(phase % TWO_PI) <= 0.0
        self.stance_flags["front"] = math.sin((phase + math.pi) % TWO_PI) <= 0.0

    def _ik(self, x: float, z: float, ref: tuple[float, float]) -> tuple[float, float]:
        """Their two-link IK in the leg frame: the solution nearer `ref`; `ref` itself when out of reach."""
        l1, l2 = self.p.thigh_m, self.p.shank_m
        d2 = x * x + z * z
        d = math.sqrt(d2)
        if d > l1 + l2 or d < abs(l1 - l2):
            return ref
        c2 = max(-1.0, min(1.0, (d2 - l1 * l1 - l2 * l2) / (2.0 * l1 * l2)))
        k = math.acos(c2)
        psi = math.atan2(z, x)
        phi = math.acos(max(-1.0, min(1.0, (d2 + l1 * l1 - l2 * l2) / (2.0 * d * l1))))
        a = (psi - phi, k)
        b = (psi + phi, -k)
        da = (a[0] - ref[0]) ** 2 + (a[1] - ref[1]) ** 2
        db = (b[0] - ref[0]) ** 2 + (b[1] - ref[1]) ** 2
        return a if da < db else b
