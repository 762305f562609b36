"""The SPARC authors' quadruped bound, re-expressed and run headless in MuJoCo: the reference gait A is
checked against.

Source (logic re-expressed here, no code copied): github.com/YueWang996/sparc, commit d9639f5, files
(sha256 of `git show d9639f5:<path>`):
  mujoco_simulation/main_robot.py
    70566aff5bd992462bb4758dd0e1798683b1caf85c85113d8e7ac0eea36f3f41
  mujoco_simulation/dog_controller_no_cpg.py
    8c028d2f23b57bbd2b173e8c95e3bd36e4961203bfcee54fb513ab6fc04d243b
  mujoco_simulation/spine_impedance_controller.py
    352d411da5a2c57449de8469cfb91dc48a22a9876435b489a8bf39290ff9b2ef
  mujoco_simulation/asset/spined_dog.xml
    75ac2f0460f40a8d8b024e8b73658a90c49057239d3beb5e87fbd9c11cc887d3
  mujoco_simulation/asset/spined_dog_spine_dyn.urdf
    20fee0c50b84b4ccca65662698c5313ebaa88005407bbdafa6e5fdfb2499629c
run on their MJCF; the spine law's model is their spine-only URDF (hind body, three spine joints, front
body, no legs), built here from the MJCF's own numbers. Copyright (c) 2026 YueWang996, MIT licence (the
notice and permission text are in the repository's LICENSE): this module carries their controller's logic
and numbers.

What it reproduces, as their code runs it:
- the MuJoCo loop: control when `data.time - last >= 1/200` (float clock: every 5 or 6 steps, ~182 Hz),
  torques held between calls, zero torque until the first call (t = 5 ms);
- the start: hind body at 0.24 m, spine q (-0.6, 1.2, -0.6), legs on the trajectory at t = 0 (feet ~2 cm in
  the floor) at the trot's phase offsets (their main_robot.py poses the legs before it switches the
  generator from its default trot to the bound: `START_PHASE_OFFSETS`), nothing else set; base pose and
  velocity read from `xpos`/`xquat`/`cvel` (one step behind
  `qpos`, as MuJoCo leaves them after `mj_step`);
- gait: phase w t + offset (kept continuous when f changes), offsets (0, 0, pi, pi) for HL, HR, FL, FR; a
  foot at (L s cos phi, H max(sin phi, 0) - 0.23) in a leg frame whose x is the robot's -x; two-link IK
  (0.151 m links) picking the solution nearest a reference pose; joint PD 8 N*m/rad, 0.1 N*m*s/rad;
- yaw PD once per cycle (kp -0.3, kd -0.1 on the heading error), stride scale 1 -+ cmd (clip +-0.4);
- spine law tau = h + J^T (Kp e + Kd de - Lambda Jdot qdot), clamped +-100 N*m (then +-12 by the MJCF),
  h and M of the spine-only model (pinocchio stands in for their `bard`: quaternion wxyz, body-frame base
  twist fed MuJoCo's `cvel` as they do, LOCAL Jacobian and spatial acceleration rotated into the hind
  body's frame: bard's `reference_frame="local"` is the body frame at the commit their code needs,
  ccfde3d, `bard/core/jacobian.py` and `kinematics.py`); schedule Kp (k_x, 2000, 15), Kd (15, 5, 1.5),
  x_d 0.273 m, then from 4 s Kd (8, 5, 0.5), x_d 0.268 m;
- frequency adaptation: the spine x (front-body origin in the hind-body frame) filtered at 6 Hz (filter
  step 5 ms), peaks above 0.02 m; the gait phase at each peak recorded over 2-4 s, its circular mean the
  target; then a lag above 0.1 rad lowers f by 1 Hz/rad (smoothed 1:1, clipped 2.8-3.2 Hz), applied at the
  next cycle start;
- fall: |roll| or |pitch| of the hind body (ZYX Euler) beyond 90 deg at a control call.
"""

from __future__ import annotations

import math
import os
import subprocess
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

# a git checkout of github.com/YueWang996/sparc (MIT), as the reproduction tier names it (tests/conftest.py)
SNAPSHOT = Path(os.environ.get("SPARC_AUTHORS_REPO", "/nonexistent-sparc-authors-repo"))
SNAPSHOT_MJCF = "mujoco_simulation/asset/spined_dog.xml"

LEG_JOINTS = ("joint_hind_left_leg_upper", "joint_hind_left_leg_lower",
              "joint_hind_right_leg_upper", "joint_hind_right_leg_lower",
              "joint_front_left_leg_upper", "joint_front_left_leg_lower",
              "joint_front_right_leg_upper", "joint_front_right_leg_lower")
SPINE_JOINTS = ("joint_hind_spine", "joint_front_spine", "joint_front_body")
SPINE_BODIES = ("hind_body", "hind_spine", "front_spine", "front_body")
# their IK's reference pose (upper, lower) per leg in robot joint angles: hind knees bend one way, front
# knees the other
IK_REFERENCE = ((-0.785398, 1.5708), (-0.785398, 1.5708), (0.785398, -1.5708), (0.785398, -1.5708))
PHASE_OFFSETS = (0.0, 0.0, math.pi, math.pi)
# their start: main_robot.py poses the legs with get_joint_angles(0.0) while the DogController's generator
# is still its default trot, and only then calls set_gait_type('bound'): the legs start at the trot's
# offsets (HL, HR, FL, FR) = (0, pi, pi, 0) (dog_controller_no_cpg.py, set_gait_type)
START_PHASE_OFFSETS = (0.0, math.pi, math.pi, 0.0)
LINK_M = 0.151
HIP_DEPTH_M = 0.23
CONTROL_PERIOD_S = 1.0 / 200.0


def snapshot_mjcf_text() -> str | None:
    """The authors' MJCF from the snapshot with its mesh assets and mesh geoms removed (all visual,
    density 0; four STLs are missing from the snapshot), or None when there is no snapshot."""
    if not (SNAPSHOT / "HEAD").exists() and not (SNAPSHOT / ".git").exists():
        return None
    r = subprocess.run(["git", "-C", str(SNAPSHOT), "show", f"HEAD:{SNAPSHOT_MJCF}"],
                       capture_output=True, text=True, check=False)
    if r.returncode != 0:
        return None
    root = ET.fromstring(r.stdout)
    strip_meshes(root)
    return ET.tostring(root, encoding="unicode")


def strip_meshes(root: ET.Element) -> None:
    """Remove the mesh assets and mesh geoms of an MJCF tree in place (all visual in their model)."""
    for asset in root.iter("asset"):
        for mesh in list(asset.findall("mesh")):
            asset.remove(mesh)
    for parent in root.iter():
        for geom in list(parent.findall("geom")):
            if geom.get("type") == "mesh":
                parent.remove(geom)


@dataclass(frozen=True)
class AuthorsBoundConfig:
    step_length_m: float = 0.12  # their `step_length`
    step_height_m: float = 0.06
    frequency_hz: float = 3.1
    k_x: float = 800.0
    duration_s: float = 20.0
    switch_s: float = 4.0
    stop_on_fall: bool = True
    start_offsets: tuple[float, float, float, float] = START_PHASE_OFFSETS  # leg phases of the start pose


@dataclass
class AuthorsBoundResult:
    t: np.ndarray  # s, every physics step (the state before that step)
    x: np.ndarray  # hind-body frame origin, world x (m)
    z: np.ndarray  # hind-body frame origin, world z (m)
    pitch: np.ndarray  # hind-body pitch about +y (rad, + nose down)
    yaw: np.ndarray
    spine_x_lp: np.ndarray  # the adaptation's 6 Hz-filtered spine x at the last control call (m)
    frequency_hz: np.ndarray
    fall_time_s: float | None
    control_calls: int
    extra: dict = field(default_factory=dict)

    def speed_m_s(self, t0: float = 2.0) -> float:
        """Mean forward speed of the hind body from t0 to the end (or the fall)."""
        w = self.t >= t0
        if w.sum() < 2:
            return float("nan")
        return float((self.x[w][-1] - self.x[w][0]) / (self.t[w][-1] - self.t[w][0]))


class AuthorsSpineLaw:
    """Their spine impedance law on the spine-only model (hind body floating, three joints, front body),
    built from the MuJoCo model's own numbers."""

    def __init__(self, m) -> None:
        import mujoco
        import pinocchio as pin

        self.pin = pin
        model = pin.Model()
        parent = 0
        for k, name in enumerate(SPINE_BODIES):
            b = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, name)
            quat = m.body_quat[b]
            rot = pin.Quaternion(quat[0], quat[1], quat[2], quat[3]).toRotationMatrix()
            place = pin.SE3.Identity() if k == 0 else pin.SE3(rot, np.array(m.body_pos[b]))
            jm = pin.JointModelFreeFlyer() if k == 0 else pin.JointModelRY()
            parent = model.addJoint(parent, jm, place, f"j_{name}")
            iq = m.body_iquat[b]
            ri = pin.Quaternion(iq[0], iq[1], iq[2], iq[3]).toRotationMatrix()
            inertia = ri @ np.diag(m.body_inertia[b]) @ ri.T
            model.appendBodyToJoint(parent, pin.Inertia(float(m.body_mass[b]), np.array(m.body_ipos[b]),
                                                        inertia), pin.SE3.Identity())
            model.addFrame(pin.Frame(name, parent, 0, pin.SE3.Identity(), pin.FrameType.BODY))
        model.gravity.linear = np.array([0.0, 0.0, -9.81])
        self.model, self.data = model, model.createData()
        self.front, self.hind = model.getFrameId("front_body"), model.getFrameId("hind_body")
        self.kp = np.array([800.0, 2000.0, 15.0])
        self.kd = np.array([15.0, 5.0, 1.5])
        self.x_des = np.array([0.273, 0.0, 0.0])
        self._q0 = pin.neutral(model)
        self._v0 = np.zeros(model.nv)

    def task(self, q_spine: np.ndarray) -> np.ndarray:
        """(x, z, pitch) of the front body in the hind-body frame."""
        pin, model, data = self.pin, self.model, self.data
        q = self._q0.copy()
        q[7:] = q_spine
        pin.framesForwardKinematics(model, data, q)
        rel = data.oMf[self.hind].actInv(data.oMf[self.front])
        r = rel.rotation
        return np.array([rel.translation[0], rel.translation[2], math.asin(max(-1.0, min(1.0, r[0, 2])))])

    def torque(self, q_full: np.ndarray, v_full: np.ndarray) -> np.ndarray:
        """q_full: base position, quaternion (w, x, y, z), 3 spine angles; v_full: base twist (linear,
        angular, read as body-frame), 3 spine rates."""
        pin, model, data = self.pin, self.model, self.data
        q_spine, v_spine = q_full[7:], v_full[6:]
        # relative kinematics on the chain with the base at the origin (their fixed-base chain)
        qk = self._q0.copy()
        qk[7:] = q_spine
        vk = self._v0.copy()
        vk[6:] = v_spine
        pin.forwardKinematics(model, data, qk, vk, np.zeros(model.nv))
        pin.updateFramePlacements(model, data)
        pin.computeJointJacobians(model, data, qk)
        rel = data.oMf[self.hind].actInv(data.oMf[self.front])
        r_rel = rel.rotation
        x_cur = np.array([rel.translation[0], rel.translation[2],
                          math.asin(max(-1.0, min(1.0, r_rel[0, 2])))])
        j_local = pin.getFrameJacobian(model, data, self.front, pin.ReferenceFrame.LOCAL)[:, 6:]
        j_hind = np.vstack([r_rel @ j_local[:3], r_rel @ j_local[3:]])
        j_task = j_hind[[0, 2, 4]]
        dx_cur = j_task @ v_spine
        acc = pin.getFrameAcceleration(model, data, self.front, pin.ReferenceFrame.LOCAL)
        jdot_v = np.concatenate([r_rel @ acc.linear, r_rel @ acc.angular])[[0, 2, 4]]
        # dynamics at the true base state
        qd = np.empty(model.nq)
        qd[:3] = q_full[:3]
        w, x, y, z = q_full[3:7]
        n = math.sqrt(w * w + x * x + y * y + z * z)
        qd[3:7] = (x / n, y / n, z / n, w / n)  # pinocchio stores (x, y, z, w)
        qd[7:] = q_spine
        h = pin.rnea(model, data, qd, v_full, np.zeros(model.nv))[6:]
        m_spine = pin.crba(model, data, qd)[6:, 6:]
        m_spine = np.triu(m_spine) + np.triu(m_spine, 1).T
        m_reg = m_spine + 1e-4 * np.eye(3)
        jmj = j_task @ np.linalg.solve(m_reg, j_task.T)
        lam = np.linalg.inv(jmj + 1e-6 * np.eye(3))
        f = self.kp * (self.x_des - x_cur) + self.kd * (0.0 - dx_cur) - lam @ jdot_v
        return np.clip(h + j_task.T @ f, -100.0, 100.0)


class AuthorsGait:
    """Their time-based trajectory generator with phase continuity and stride-length steering."""

    def __init__(self, cfg: AuthorsBoundConfig) -> None:
        self.L, self.H = cfg.step_length_m, cfg.step_height_m
        self.w = 2 * math.pi * cfg.frequency_hz
        self.frequency_hz = cfg.frequency_hz
        self.offset = 0.0
        self.scale_left = self.scale_right = 1.0

    def set_frequency(self, f_hz: float, t_s: float) -> None:
        phase = self.w * t_s + self.offset
        self.frequency_hz, self.w = f_hz, 2 * math.pi * f_hz
        self.offset = phase - self.w * t_s

    def phase(self, t_s: float) -> float:
        return (self.w * t_s + self.offset) % (2 * math.pi)

    def steer(self, cmd: float) -> None:
        cmd = max(-0.4, min(0.4, cmd))
        self.scale_right, self.scale_left = 1.0 + cmd, 1.0 - cmd

    def joint_targets(self, t_s: float, offsets: tuple[float, ...] = PHASE_OFFSETS) -> np.ndarray:
        g = self.w * t_s + self.offset
        out = np.zeros(8)
        for i in range(4):
            ph = (g + offsets[i]) % (2 * math.pi)
            s = math.sin(ph)
            scale = self.scale_left if i % 2 == 0 else self.scale_right
            xl = self.L * scale * math.cos(ph)  # leg frame: x is the robot's -x
            zl = (self.H * s if s > 0 else 0.0) - HIP_DEPTH_M
            out[2 * i:2 * i + 2] = _leg_ik(xl, zl, IK_REFERENCE[i])
        return out


def _leg_ik(x: float, z: float, ref: tuple[float, float]) -> tuple[float, float]:
    """Two-link IK in the leg frame, the solution nearest the reference; robot joint angles (the leg
    frame's angle is the robot's minus pi/2 at the hip)."""
    l1 = l2 = LINK_M
    ref_gen = (ref[0] + math.pi / 2, ref[1])
    d2 = x * x + z * z
    d = math.sqrt(d2)
    if d > l1 + l2 or d < abs(l1 - l2):
        q1, q2 = ref_gen
    else:
        c2 = max(-1.0, min(1.0, (d2 - l1 * l1 - l2 * l2) / (2 * l1 * l2)))
        k = math.acos(c2)
        psi = math.atan2(z, x)
        phi = math.acos(max(-1.0, min(1.0, (d2 + l1 * l1 - l2 * l2) / (2 * d * l1))))
        a, b = (psi - phi, k), (psi + phi, -k)
        da = (a[0] - ref_gen[0]) ** 2 + (a[1] - ref_gen[1]) ** 2
        db = (b[0] - ref_gen[0]) ** 2 + (b[1] - ref_gen[1]) ** 2
        q1, q2 = a if da < db else b
    return q1 + math.pi / 2, q2


def _rpy(quat: np.ndarray) -> tuple[float, float, float]:
    w, x, y, z = quat
    roll = math.atan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
    sp = 2 * (w * y - z * x)
    pitch = math.copysign(math.pi / 2, sp) if abs(sp) >= 1 else math.asin(sp)
    yaw = math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
    return roll, pitch, yaw


def load_model(mjcf_xml: str | None = None, mjcf_path: Path | None = None):
    import mujoco

    if mjcf_path is not None:
        return mujoco.MjModel.from_xml_path(str(mjcf_path))
    text = mjcf_xml if mjcf_xml is not None else snapshot_mjcf_text()
    if text is None:
        raise FileNotFoundError("no MJCF given and no snapshot of the authors' repository")
    return mujoco.MjModel.from_xml_string(text)


def run_authors_bound(cfg: AuthorsBoundConfig, model=None) -> AuthorsBoundResult:
    """Run their bound on `model` (an MjModel of the spined dog; default: the snapshot's MJCF)."""
    import mujoco

    m = model if model is not None else load_model()
    d = mujoco.MjData(m)

    def jid(name: str) -> int:
        return mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, name)

    def aid(name: str) -> int:
        return mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_ACTUATOR, name.replace("joint_", "motor_"))

    leg_q = [int(m.jnt_qposadr[jid(n)]) for n in LEG_JOINTS]
    leg_v = [int(m.jnt_dofadr[jid(n)]) for n in LEG_JOINTS]
    sp_q = [int(m.jnt_qposadr[jid(n)]) for n in SPINE_JOINTS]
    sp_v = [int(m.jnt_dofadr[jid(n)]) for n in SPINE_JOINTS]
    leg_a = [aid(n) for n in LEG_JOINTS]
    sp_a = [aid(n) for n in SPINE_JOINTS]
    hind = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, "hind_body")
    front = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, "front_body")

    law = AuthorsSpineLaw(m)
    law.kp = np.array([cfg.k_x, 2000.0, 15.0])
    gait = AuthorsGait(cfg)
    for a, q in zip(sp_q, (-0.6, 1.2, -0.6), strict=True):
        d.qpos[a] = q
    for a, q in zip(leg_q, gait.joint_targets(0.0, cfg.start_offsets), strict=True):
        d.qpos[a] = q

    # control-loop state
    last_call = 0.0
    last_phase_main = 0.0  # the loop's own wrap detector (frequency updates)
    last_phase_ctrl = 0.0  # the dog controller's (steering)
    last_known_time = 0.0
    last_yaw_err = 0.0
    switched = False
    lpf_alpha = CONTROL_PERIOD_S / (1.0 / (2 * math.pi * 6.0) + CONTROL_PERIOD_S)
    lpf = None
    xbuf: list[float] = []
    tbuf: list[float] = []
    baseline: list[float] = []
    target_phase = None
    calibrated = False
    pending_f = None
    calls = 0

    n = round(cfg.duration_s / m.opt.timestep)
    log = np.zeros((n, 7))
    fall_t = None
    i = 0
    for i in range(n):
        t = d.time
        if t - last_call >= CONTROL_PERIOD_S:
            last_call = t
            calls += 1
            now = gait.phase(t)
            if now < last_phase_main and pending_f is not None:
                gait.set_frequency(pending_f, last_known_time)
                pending_f = None
            last_phase_main = now
            if t >= cfg.switch_s and not switched:
                law.kd = np.array([8.0, 5.0, 0.5])
                law.x_des = np.array([0.268, 0.0, 0.0])
                switched = True
            roll, pitch, _ = _rpy(d.xquat[hind])
            if abs(roll) > math.pi / 2 or abs(pitch) > math.pi / 2:
                fall_t = t
                if cfg.stop_on_fall:
                    break
            q_full = np.concatenate([d.xpos[hind], d.xquat[hind], d.qpos[sp_q]])
            v_full = np.concatenate([d.cvel[hind, 3:6], d.cvel[hind, 0:3], d.qvel[sp_v]])
            # the dog controller: steering at its own wrap, leg PD, spine law
            last_known_time = t
            ph = gait.phase(t)
            if ph < last_phase_ctrl:
                _, _, yaw = _rpy(q_full[3:7])
                err = 0.0 - yaw
                gait.steer(-0.3 * err - 0.1 * (err - last_yaw_err))
                last_yaw_err = err
            last_phase_ctrl = ph
            q_des = gait.joint_targets(t)
            tau_legs = 8.0 * (q_des - d.qpos[leg_q]) + 0.1 * (0.0 - d.qvel[leg_v])
            tau_spine = law.torque(q_full, v_full)
            d.ctrl[leg_a] = tau_legs
            d.ctrl[sp_a] = tau_spine
            # frequency adaptation: peaks of the filtered spine x
            rot = d.xmat[hind].reshape(3, 3)
            sx = float((rot.T @ (d.xpos[front] - d.xpos[hind]))[0])
            lpf = sx if lpf is None else lpf_alpha * sx + (1 - lpf_alpha) * lpf
            xbuf.append(lpf)
            tbuf.append(t)
            if len(xbuf) > 200:
                xbuf.pop(0)
                tbuf.pop(0)
            if len(xbuf) > 5 and xbuf[-2] > xbuf[-1] and xbuf[-2] > xbuf[-3] and xbuf[-2] > 0.02:
                peak_phase = gait.phase(tbuf[-2])
                if t < cfg.switch_s:
                    if t > 2.0:
                        baseline.append(peak_phase)
                elif not calibrated:
                    sin_sum, cos_sum = float(np.sum(np.sin(baseline))), float(np.sum(np.cos(baseline)))
                    target_phase = math.atan2(sin_sum, cos_sum) if baseline else 0.0
                    calibrated = True
                else:
                    lag = (peak_phase - target_phase + math.pi) % (2 * math.pi) - math.pi
                    if lag > 0.1:
                        f_new = min(3.2, max(2.8, gait.frequency_hz - lag))
                        f_s = 0.5 * f_new + 0.5 * gait.frequency_hz
                        if abs(f_s - gait.frequency_hz) > 0.01:
                            pending_f = f_s
        # the log takes the present state (qpos; xpos lags it by a step): free joint = hind-body frame
        _, pitch, yaw = _rpy(d.qpos[3:7])
        log[i] = (t, d.qpos[0], d.qpos[2], pitch, yaw, lpf if lpf is not None else 0.0, gait.frequency_hz)
        mujoco.mj_step(m, d)
    else:
        i = n
    s = log[:i]
    return AuthorsBoundResult(t=s[:, 0], x=s[:, 1], z=s[:, 2], pitch=s[:, 3], yaw=s[:, 4], spine_x_lp=s[:, 5],
                              frequency_hz=s[:, 6], fall_time_s=fall_t, control_calls=calls,
                              extra={"target_peak_phase": target_phase, "baseline_peaks": len(baseline)})


if __name__ == "__main__":  # python -m tests.reference.authors_bound [step_length] [k_x] [duration]
    import sys

    args = [float(a) for a in sys.argv[1:]]
    c = AuthorsBoundConfig(*(args[:1]), k_x=args[1] if len(args) > 1 else 800.0,
                           duration_s=args[2] if len(args) > 2 else 20.0)
    r = run_authors_bound(c)
    print(f"L={c.step_length_m} k_x={c.k_x}: fall={r.fall_time_s} speed(2 s-end)={r.speed_m_s():.3f} m/s "
          f"calls={r.control_calls} ({r.control_calls / max(r.t[-1], 1e-9):.1f} Hz) "
          f"f_end={r.frequency_hz[-1]:.3f}"
          f" yaw_end={r.yaw[-1]:.3f} target={r.extra['target_peak_phase']}")
