"""The quadruped world in MuJoCo (`mujoco` from PyPI, the [mujoco] extra): torque motors on every joint,
a plane tilted about y for the slope, the SPARC authors' solver options.

The spined dog loads its own MJCF (robots/spined_dog/spined_dog.xml, the authors' options: dt 1 ms, CG,
1000 iterations, tolerance 1e-8, elliptic cones, noslip 2). The spliced Solo12 and A1 load their URDF
through `mujoco.MjSpec`, which gets a free joint, the same floor and options, and a motor per joint.
The robot's geoms collide with the floor only (contype 2, conaffinity 1 against the floor's 1 / 1), as
pybullet's URDF robots do without self-collision. Friction is the floor's (priority 1): the foot-ground
coefficient is `friction`, where pybullet multiplies the foot's and the ground's (friction squared).

After `mj_step` the positions and velocities are the new state; the contacts are those the step solved
(at its start), as pybullet's contact points after stepSimulation. So are the x-quantities (`xpos`,
`xquat`, `cvel`): one step behind `qpos`, which is how the SPARC authors' code reads its base pose and twist
(`authors_twist`, WorldConfig.base_motion "authors-cvel").
"""

from __future__ import annotations

import math
import operator
import struct
import time
from pathlib import Path

import mujoco
import numpy as np

from sparc_quad.robots import ROBOTS_DIR
from sparc_quad.sim import spined_dog
from sparc_quad.sim.quadruped_world import (
    ABSENT,
    HELD_STATE,
    QuadWorld,
    WorldConfig,
    quat_about_y,
)

FLOOR = "floor"
LOCK_SOLREF = (0.002, 1.0)  # equality time constant of a locked spine joint: 2 steps of 1 ms
# mjSENS_CONTACT's intprm: data found | force (bits 1, 2), reduce by the largest force (2), one contact
FOOT_SENSOR_INTPRM = (3, 2, 1)
STATE_ALL = mujoco.mjtState.mjSTATE_INTEGRATION  # what a rewind restores: state, warm start, controls


def _options(spec: mujoco.MjSpec, cfg: WorldConfig) -> None:
    ph = spined_dog.PHYSICS
    o = spec.option
    o.timestep = cfg.dt_s
    o.iterations = ph.iterations
    o.tolerance = ph.tolerance
    o.impratio = ph.impratio
    o.solver = getattr(mujoco.mjtSolver, f"mjSOL_{ph.solver}")
    o.cone = getattr(mujoco.mjtCone, f"mjCONE_{ph.cone.upper()}")
    o.noslip_iterations = ph.noslip_iterations
    o.gravity = [0.0, 0.0, -cfg.gravity_m_s2]


def _from_urdf(path: Path, meta: dict) -> mujoco.MjSpec:
    """A URDF robot as an MJCF spec: fixed links kept as bodies (the feet), free joint, floor, motors."""
    spec = mujoco.MjSpec.from_file(str(path))
    spec.compiler.fusestatic = False
    spec.compiler.discardvisual = True
    root = spec.worldbody.first_body()
    root.add_freejoint(name="root")
    for g in spec.geoms:
        g.contype, g.conaffinity = 2, 1
    spec.worldbody.add_geom(name=FLOOR, type=mujoco.mjtGeom.mjGEOM_PLANE, size=[30, 30, 0.1], contype=1,
                            conaffinity=1, priority=1)
    spine = set(meta["spine_joints"])
    for j in spec.joints:
        if j.type != mujoco.mjtJoint.mjJNT_HINGE:
            continue
        lim = meta["spine_torque_limit_nm"] if j.name in spine else meta["leg_torque_limit_nm"]
        spec.add_actuator(name=f"motor_{j.name}", target=j.name, trntype=mujoco.mjtTrn.mjTRN_JOINT,
                          ctrllimited=mujoco.mjtLimited.mjLIMITED_TRUE, ctrlrange=[-lim, lim])
    return spec


def _pitch_rate_roll_yaw(rot: tuple[float, ...], wx: float, wy: float, wz: float) -> tuple[float, ...]:
    """(q1 = pitch, dq1 = pitch rate (world y of R w), roll, yaw) from the rotation matrix `rot`
    (`_rotation`) and the free joint's body-frame angular velocity: `read`'s and the chunks' one formula."""
    return (math.atan2(-rot[6], rot[0]), rot[3] * wx + rot[4] * wy + rot[5] * wz, math.atan2(rot[7], rot[8]),
            math.atan2(rot[3], rot[0]))


def _body_twist(rot: tuple[float, ...], qv: list[float]) -> tuple[float, ...]:
    """The free joint's twist in the body frame: (R^T v, w) from its qvel (v world axes, w body frame):
    `base_twist`'s and the chunks' one formula."""
    vx, vy, vz = qv[0], qv[1], qv[2]
    return (rot[0] * vx + rot[3] * vy + rot[6] * vz, rot[1] * vx + rot[4] * vy + rot[7] * vz,
            rot[2] * vx + rot[5] * vy + rot[8] * vz, qv[3], qv[4], qv[5])


def _rotation(qw: float, qx: float, qy: float, qz: float) -> tuple[float, ...]:
    """Row-major rotation matrix (9 floats) of a unit quaternion."""
    return (1 - 2 * (qy * qy + qz * qz), 2 * (qx * qy - qw * qz), 2 * (qx * qz + qw * qy),
            2 * (qx * qy + qw * qz), 1 - 2 * (qx * qx + qz * qz), 2 * (qy * qz - qw * qx),
            2 * (qx * qz - qw * qy), 2 * (qy * qz + qw * qx), 1 - 2 * (qx * qx + qy * qy))


def _quat_wxyz(xyzw) -> list[float]:
    x, y, z, w = xyzw
    return [w, x, y, z]


class MujocoWorld(QuadWorld):
    """One MuJoCo model and data with the spined quadruped standing on its four feet at t = 0."""

    engine = "mujoco"
    cvel_lag_steps = 1  # `authors_twist` reads `cvel`, which mj_step leaves at the state before the step

    def __init__(self, cfg: WorldConfig | None = None, robots_dir: Path = ROBOTS_DIR):
        super().__init__(cfg, robots_dir)
        cfg, files = self.cfg, self.files
        meta = self.meta
        spec = mujoco.MjSpec.from_file(str(files.mjcf)) if files.mjcf else _from_urdf(files.urdf, meta)
        _options(spec, cfg)
        floor = spec.geom(FLOOR)
        floor.quat = _quat_wxyz(quat_about_y(-cfg.slope_rad))
        floor.friction = [cfg.friction, *spined_dog.PHYSICS.floor_friction[1:]]
        if cfg.lock_spine:
            q_eq = meta["q_equilibrium"][1:] if cfg.lock_spine_q_rad is None else cfg.lock_spine_q_rad
            for name, q in zip(meta["spine_joints"], q_eq, strict=True):
                data = np.zeros(mujoco.mjNEQDATA)
                data[0] = q
                spec.add_equality(type=mujoco.mjtEq.mjEQ_JOINT, name1=name, data=data, solref=LOCK_SOLREF)
        # a contact sensor per foot (found, normal force, two friction components of the contact with the
        # largest force): the chunked steps' foot contacts, one copy per step; sensors do not act
        for leg, v in self.legs.items():
            spec.add_sensor(name=f"contact_{leg}", type=mujoco.mjtSensor.mjSENS_CONTACT,
                            objtype=mujoco.mjtObj.mjOBJ_BODY, objname=v["foot_link"],
                            reftype=mujoco.mjtObj.mjOBJ_GEOM, refname=FLOOR, intprm=FOOT_SENSOR_INTPRM)
        self.spec = spec
        self.model = m = spec.compile()
        if cfg.mass_scale != 1.0:
            m.body_mass[1:] *= cfg.mass_scale
            m.body_inertia[1:] *= cfg.mass_scale
        hinge = mujoco.mjtJoint.mjJNT_HINGE
        hinge_dofs = [int(m.jnt_dofadr[j]) for j in range(m.njnt) if m.jnt_type[j] == hinge]
        m.dof_damping[hinge_dofs] = cfg.joint_damping_nm_s_rad
        m.dof_frictionloss[hinge_dofs] = cfg.joint_friction_nm
        if cfg.leg_torque_limit_nm is not None:  # every motor but the spine's
            spine_j = {m.joint(n).id for n in meta["spine_joints"]}
            for a in range(m.nu):
                j = int(m.actuator_trnid[a, 0])
                if j not in spine_j:
                    lim = cfg.leg_torque_limit_nm
                    m.actuator_ctrlrange[a] = (-lim, lim)
                    m.jnt_actfrcrange[j] = (-lim, lim)
        self.data = mujoco.MjData(m)
        self.total_mass = float(m.body_mass[1:].sum())
        hinges = {m.joint(i).name: i for i in range(m.njnt) if m.jnt_type[i] == mujoco.mjtJoint.mjJNT_HINGE}
        self._index_joints(hinges)
        engine_joints = [j for j in self.movable if j != ABSENT]
        self.n_engine_joints = len(engine_joints)
        self._qadr_list = [int(m.jnt_qposadr[j]) for j in engine_joints]
        self._dadr_list = [int(m.jnt_dofadr[j]) for j in engine_joints]

        def as_slice(adr: list[int]) -> slice | None:
            return slice(adr[0], adr[-1] + 1) if adr == list(range(adr[0], adr[-1] + 1)) else None

        self._qslice, self._dslice = as_slice(self._qadr_list), as_slice(self._dadr_list)
        act_of = {int(m.actuator_trnid[a, 0]): a for a in range(m.nu)}
        ctrl_idx = [act_of[j] for j in engine_joints]
        self._ctrl_idx = slice(None) if ctrl_idx == list(range(m.nu)) else np.array(ctrl_idx)
        self._pad = [0.0] * (len(self.movable) - len(engine_joints))
        base = m.body(meta["base_link"]).id
        self._base = base
        self._floor = m.geom(FLOOR).id
        foot_body = {m.body(v["foot_link"]).id: k for k, v in self.legs.items()}
        # bodies below each leg's first joint are the leg's; the others (trunk, spine) are "body"
        leg_roots = {m.jnt_bodyid[self.joint_index[v["haa"] or v["hfe"]]] for v in self.legs.values()}

        def in_leg(b: int) -> bool:
            while b > 0:
                if b in leg_roots:
                    return True
                b = int(m.body_parentid[b])
            return False

        self._geom_foot = {g: foot_body[m.geom_bodyid[g]] for g in range(m.ngeom)
                           if m.geom_bodyid[g] in foot_body}
        self._geom_body = {g for g in range(m.ngeom) if m.geom_bodyid[g] > 0 and not in_leg(m.geom_bodyid[g])}
        self._cf = np.zeros(6)
        self._elliptic = m.opt.cone == mujoco.mjtCone.mjCONE_ELLIPTIC
        # MjData's fixed-size arrays as numpy views, made once (each `d.qpos` builds a new view); they stay
        # valid for the life of `self.data`
        self._qpos, self._qvel, self._ctrl = self.data.qpos, self.data.qvel, self.data.ctrl
        self._cvel_base = self.data.cvel[base]  # the hind body's (rot; lin) at the robot's COM, world axes
        front = int(m.jnt_bodyid[self.joint_index[meta["spine_joints"][-1]]])  # the last spine joint's body
        d = self.data
        self._authors_views = (d.xpos[base], d.xmat[base], d.cvel[base], d.xmat[front], d.cvel[front])
        self._chunk_cvel = self.estimator.uses_authors_twist  # step_chunk keeps each step's cvel
        self._ctrl_all = isinstance(self._ctrl_idx, slice) and self._ctrl.flags.c_contiguous
        self._pack_ctrl = struct.Struct(f"{m.nu}d").pack_into
        # chunked held steps (step_chunk): their states are kept raw (qpos, qvel, the foot sensors) and
        # converted after the run; the spine's q and dq are read straight from qpos and qvel rows
        qadr, dadr = self._qadr_list, self._dadr_list
        self._spine_qadr = [qadr[p] for p in self._spine_pos]
        self._spine_dadr = [dadr[p] for p in self._spine_pos]
        self._held_q = operator.itemgetter(*self._spine_qadr)
        self._held_dq = operator.itemgetter(*self._spine_dadr)
        self._leg_dadr = [dadr[self.pos_in_movable[j]] if j != ABSENT else -1
                          for k in ("HL", "HR", "FL", "FR") for j in self.leg_idx[k]]
        self._sens = self.data.sensordata
        force_adr = {k: int(m.sensor_adr[m.sensor(f"contact_{k}").id]) + 1 for k in self.legs}
        self._foot_keys = tuple(self.legs)
        self._foot_forces = operator.itemgetter(*(force_adr[k] for k in self._foot_keys))  # read's order
        self._held_force_adr = [force_adr[k] for k in ("HL", "HR", "FL", "FR")]  # HELD_STATE's
        self.can_rewind = False  # read's contact scan until the check below
        self.can_rewind = self._contacts_are_feet_on_floor()
        self._snap = np.zeros(mujoco.mj_stateSize(m, STATE_ALL))
        self.reset_stand(pitch_rad=-cfg.slope_rad + cfg.init_pitch_rad)
        if cfg.init_vx_m_s:
            self.data.qvel[0] = cfg.init_vx_m_s
            mujoco.mj_comVel(self.model, self.data)  # cvel of that state, as mj_forward left it at rest
            self.read()

    # ---- set-up ---------------------------------------------------------------------------------------
    def reset_stand(self, pitch_rad: float | None = None) -> None:
        m, d, cfg = self.model, self.data, self.cfg
        pitch = -cfg.slope_rad if pitch_rad is None else pitch_rad
        mujoco.mj_resetData(m, d)
        q_spine, legs = self.stand_pose()
        for name, q in zip(self.meta["spine_joints"], q_spine, strict=True):
            d.qpos[m.jnt_qposadr[self.joint_index[name]]] = q
        for key, (haa, hfe, kfe) in self.leg_idx.items():
            if haa != ABSENT:
                d.qpos[m.jnt_qposadr[haa]] = 0.0
            d.qpos[m.jnt_qposadr[hfe]], d.qpos[m.jnt_qposadr[kfe]] = legs[key]
        n = (math.sin(-cfg.slope_rad), 0.0, math.cos(-cfg.slope_rad))  # ground normal
        h = self.stand_frame_height_m()
        d.qpos[0:3] = [n[0] * h, n[1] * h, n[2] * h]
        d.qpos[3:7] = _quat_wxyz(quat_about_y(pitch))
        mujoco.mj_forward(m, d)
        self.t = 0.0
        self.steps = 0
        self.read()

    def com_x(self) -> float:
        mujoco.mj_kinematics(self.model, self.data)
        mujoco.mj_comPos(self.model, self.data)
        return float(self.data.subtree_com[self._base][0])

    # ---- state ---------------------------------------------------------------------------------------
    def read(self) -> None:
        qp = self._qpos.tolist()  # one conversion each, then plain floats (the per-step cost is Python's)
        qv = self._qvel.tolist()
        px, py, pz, qw, qx, qy, qz = qp[:7]
        vx, vy, vz, wx, wy, wz = qv[:6]
        self._qv6 = qv[:6]
        rot = _rotation(qw, qx, qy, qz)
        self.base_pos = (px, py, pz)
        self.base_vel = (vx, vy, vz)  # the free joint's linear velocity: of the frame origin, world axes
        self.base_quat = (qx, qy, qz, qw)
        self.base_rot = rot
        # the free joint's angular velocity is in the body frame: world axes = R w
        w = (rot[0] * wx + rot[1] * wy + rot[2] * wz, rot[3] * wx + rot[4] * wy + rot[5] * wz,
             rot[6] * wx + rot[7] * wy + rot[8] * wz)
        self.base_omega = w
        # q1 = pitch_of(base_quat) from the same matrix; dq1 = w[1]
        self.q1, self.dq1, self.roll, self.yaw = _pitch_rate_roll_yaw(rot, wx, wy, wz)
        qa, da = self._qslice, self._dslice
        if qa is not None:
            self.jq = jq = qp[qa] + self._pad
            self.jdq = jdq = qv[da] + self._pad
        else:
            self.jq = jq = [qp[i] for i in self._qadr_list] + self._pad
            self.jdq = jdq = [qv[i] for i in self._dadr_list] + self._pad
        spine = self._spine_of
        self.q_spine = spine(jq)
        self.dq_spine = spine(jdq)
        self._read_contacts()

    def base_twist(self) -> tuple[float, ...]:
        """`QuadWorld.base_twist` from the free joint's qvel (its angular velocity is body-frame already)."""
        return _body_twist(self.base_rot, self._qv6)

    def authors_twist(self) -> tuple[float, ...]:
        """`QuadWorld.authors_twist`: `cvel` of the hind body as it is now, the state before the last step
        (the first state's after `reset_stand`'s mj_forward), reordered (lin; rot)."""
        wx, wy, wz, vx, vy, vz = self._cvel_base.tolist()
        return (vx, vy, vz, wx, wy, wz)

    def authors_body_states(self) -> tuple:
        """`QuadWorld.authors_body_states` from MjData, as the authors' loop reads it after mj_step."""
        pos, rot, cvel, front_rot, front_cvel = self._authors_views
        c, fc = cvel.tolist(), front_cvel.tolist()
        return (tuple(pos.tolist()), tuple(rot.tolist()), tuple(c[3:]), tuple(c[:3]),
                tuple(front_rot.tolist()), tuple(fc[3:]))

    def _read_contacts(self) -> None:
        """contact_force, other_contact, body_contact from the contacts the last step solved."""
        if self.can_rewind:  # one sphere per foot on the plane, nothing else touches it: the foot sensors
            forces = self._foot_forces(self._sens.tolist())
            self.contact_force = dict(zip(self._foot_keys, forces, strict=True))
            self.other_contact = self.body_contact = False
            return
        d = self.data
        self.contact_force = force = dict.fromkeys(self.legs, 0.0)
        self.other_contact = False
        self.body_contact = False
        ncon = d.ncon
        if ncon:
            con = d.contact
            geoms = con.geom.tolist()
            feet, floor, cf, m = self._geom_foot, self._floor, self._cf, self.model
            # elliptic cones: a contact's first constraint row is its normal force (what mj_contactForce
            # copies); pyramidal ones need mj_contactForce's conversion
            if self._elliptic:
                adr = con.efc_address.tolist()
                efc = d.efc_force.tolist()  # the same doubles as float(d.efc_force[a]), one conversion
            else:
                adr = efc = None
            for i in range(ncon):
                g1, g2 = geoms[i]
                other = g2 if g1 == floor else g1 if g2 == floor else None
                if other is None:
                    continue
                key = feet.get(other)
                if key is None:
                    self.other_contact = True
                    self.body_contact |= other in self._geom_body
                elif adr is not None:
                    a = adr[i]
                    if a >= 0:
                        force[key] += efc[a]
                else:
                    mujoco.mj_contactForce(m, d, i, cf)
                    force[key] += float(cf[0])

    def step(self) -> None:
        self._set_ctrl()
        self._mj_step()
        self.read()

    def _set_ctrl(self) -> None:
        tau = self._tau if not self._pad else self._tau[:self.n_engine_joints]
        if self._ctrl_all:  # packed as doubles into ctrl's buffer (the same conversion numpy makes)
            self._pack_ctrl(self._ctrl, 0, *tau)
        else:
            self._ctrl[self._ctrl_idx] = tau

    def _mj_step(self) -> None:
        t0 = time.perf_counter()
        mujoco.mj_step(self.model, self.data)
        self.physics_wall_s += time.perf_counter() - t0
        self.steps += 1
        self.t = self.steps * self.cfg.dt_s

    def _contacts_are_feet_on_floor(self) -> bool:
        """Whether every contact with the floor is one foot sphere on the plane (one contact per foot, no
        body contact): then the foot sensors give exactly the flags `read` computes, and chunks are exact."""
        m = self.model
        floor = self._floor
        if m.geom_type[floor] != mujoco.mjtGeom.mjGEOM_PLANE:
            return False
        per_foot: dict[str, int] = {}
        for g in range(m.ngeom):
            if g == floor or not (m.geom_contype[g] & m.geom_conaffinity[floor]
                                  or m.geom_contype[floor] & m.geom_conaffinity[g]):
                continue
            key = self._geom_foot.get(g)
            if key is None or m.geom_type[g] != mujoco.mjtGeom.mjGEOM_SPHERE:
                return False
            per_foot[key] = per_foot.get(key, 0) + 1
        return all(v == 1 for v in per_foot.values())

    def _need_chunks(self) -> None:
        if not self.can_rewind:  # run_bound checks can_rewind first: reaching this is a caller's bug
            raise NotImplementedError("this MuJoCo world's contacts are not feet on a floor plane only: "
                                      "its steps cannot be chunked")

    def start_held(self, n_rows: int) -> None:
        self._need_chunks()
        self._qb = np.zeros((n_rows, self.model.nq))
        self._vb = np.zeros((n_rows, self.model.nv))
        self._sb = np.zeros((n_rows, self.model.nsensordata))
        self._cb = np.zeros((n_rows, 6)) if self._chunk_cvel else None

    def step_chunk(self, k: int, row: int) -> list[tuple]:
        """`QuadWorld.step_chunk` as k mj_steps back to back, each new state's qpos, qvel and foot sensors
        copied into the run's buffers, then converted."""
        self._need_chunks()
        m, d, step, clock = self.model, self.data, mujoco.mj_step, time.perf_counter
        qpos, qvel, sens, qb, vb, sb = self._qpos, self._qvel, self._sens, self._qb, self._vb, self._sb
        self._set_ctrl()
        mujoco.mj_getState(m, d, self._snap, STATE_ALL)  # for `rewind`
        steps0 = self.steps
        self._chunk = (row, steps0)
        wall = 0.0
        cb = self._cb  # the authors' twist: each new state's cvel (that of the state before it) as well
        cvel = self._cvel_base if cb is not None else None
        for j in range(row + 1, row + k + 1):
            t0 = clock()
            step(m, d)
            wall += clock() - t0
            qb[j] = qpos
            vb[j] = qvel
            sb[j] = sens
            if cb is not None:
                cb[j] = cvel
        self.physics_wall_s += wall
        self.steps = steps0 + k
        self.t = self.steps * self.cfg.dt_s
        self.read()
        # each new state as `read` converts it (the same formulas and order), element by element
        dt, held_q, held_dq = self.cfg.dt_s, self._held_q, self._held_dq
        rotation, angles, body_twist = _rotation, _pitch_rate_roll_yaw, _body_twist
        twist = self.estimator.needs_twist
        rows = slice(row + 1, row + k + 1)
        qs, vs = qb[rows].tolist(), vb[rows].tolist()
        cs = cb[rows].tolist() if cb is not None else None
        states = []
        append = states.append
        for r in range(k):
            qp, qv = qs[r], vs[r]
            rot = rotation(qp[3], qp[4], qp[5], qp[6])
            q1, dq1, roll, yaw = angles(rot, qv[3], qv[4], qv[5])
            if cs is not None:  # as `authors_twist`
                c = cs[r]
                tw = (c[3], c[4], c[5], c[0], c[1], c[2])
            else:
                tw = body_twist(rot, qv) if twist else None
            append(((steps0 + r + 1) * dt, q1, dq1, roll, yaw, held_q(qp), held_dq(qv), False, tw))
        return states

    def rewind(self, r: int) -> None:
        """Back to the chunk's r-th new state (r >= 1): its start restored, r steps redone (deterministic:
        the same state, warm start and controls give the same doubles), read in full."""
        if r < 1:
            raise ValueError(f"rewind to a chunk's r-th state needs r >= 1, got {r}")
        _, steps0 = self._chunk
        m, d = self.model, self.data
        mujoco.mj_setState(m, d, self._snap, STATE_ALL)
        t0 = time.perf_counter()
        mujoco.mj_step(m, d, nstep=r)
        self.physics_wall_s += time.perf_counter() - t0
        self.steps = steps0 + r
        self.t = self.steps * self.cfg.dt_s
        self.read()

    def held_rows(self, rows: np.ndarray) -> np.ndarray:
        """The HELD_STATE values of the states before steps `rows`, copied from the raw buffers (the
        foot flags: the sensors' normal force > 0, as `read`'s)."""
        self._need_chunks()
        qp, qv, sn = self._qb[rows], self._vb[rows], self._sb[rows]
        out = np.zeros((len(rows), len(HELD_STATE)))
        out[:, 0:3] = qp[:, 0:3]
        out[:, 3:6] = qp[:, self._spine_qadr]
        out[:, 6:9] = qv[:, self._spine_dadr]
        out[:, 9:13] = sn[:, self._held_force_adr] > 0.0
        legs = np.asarray(self._leg_dadr)
        present = legs >= 0
        out[:, 13:][:, present] = qv[:, legs[present]]
        return out

    def close(self) -> None:
        renderer = getattr(self, "_renderer", None)
        if renderer is not None:
            renderer.close()
            self._renderer = None

    def render(self, width: int = 480, height: int = 320) -> np.ndarray:
        """An RGB frame from MuJoCo's renderer (needs an OpenGL context: MUJOCO_GL=egl or osmesa when
        headless), camera following the robot."""
        if getattr(self, "_renderer", None) is None:
            self._renderer = mujoco.Renderer(self.model, height, width)
            self._camera = mujoco.MjvCamera()
            self._camera.distance, self._camera.azimuth, self._camera.elevation = 0.9, 90.0, -10.0
            self._scene_option = mujoco.MjvOption()
            self._scene_option.geomgroup[:] = 1  # the foot spheres are in group 3 (hidden by default)
        x, y, z = self.base_pos
        self._camera.lookat[:] = (x + 0.15, y, z - 0.05)
        self._renderer.update_scene(self.data, self._camera, self._scene_option)
        return self._renderer.render().copy()
