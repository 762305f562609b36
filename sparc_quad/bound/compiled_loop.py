"""A bound's loop with its control half in one compiled call per step (`bound.step_kernel`): the step loop
(`bound.stepping`) `bound.loops.choose_loop` picks when the run's per-step code is compiled and the step is
the plain one (see `CompiledLoop.why_not`).

Each step: the world's state packed into the kernel's input, the kernel (estimate, spine, legs, torque
order, log row, fall test), the torques handed to the world, the world's step. The estimator, the spine
controller and the bound controller keep their state in their own arrays, so after the loop they stand
where the reference loop would have left them.
"""

from __future__ import annotations

import struct

import numpy as np

from sparc_quad.bound import step_kernel as sk
from sparc_quad.bound.stepping import Ended, Steps
from sparc_quad.sim.bound_log import COLUMNS, DERIVED, LEG_JOINTS, LEGS
from sparc_quad.sim.fall import FALL_REASONS

_COLS = np.array([COLUMNS.index(c) for c in (*sk.KERNEL_ROW, *(f"tau_{j}" for j in LEG_JOINTS),
                                             *(f"dq_{j}" for j in LEG_JOINTS))], dtype=np.int64)
if sorted((*(COLUMNS[c] for c in _COLS), *DERIVED)) != sorted(COLUMNS):
    raise RuntimeError("the compiled step must write every log column but the derived ones, once")


class CompiledLoop:
    """The loop of one bound over `world`, `spine` (a DirectSpine) and `gait` (a CompiledBoundController)."""

    name = "compiled"
    why = "the spine law and the bound controller are compiled and the estimator's base motion is fixed"

    @staticmethod
    def why_not(world, spine, gait) -> str | None:
        """Why this world, spine and gait cannot run here (None: they can)."""
        from sparc_quad.gaits.bound_fast import CompiledBoundController
        from sparc_quad.sim.sim_spine import DirectSpine

        if not isinstance(spine, DirectSpine) or spine.compiled_law() is None:
            return "the spine is not the compiled impedance law run every step in process"
        if type(gait) is not CompiledBoundController:
            return "the gait is not the compiled bound controller"
        est = world.estimator
        if est.needs_twist:
            return f"the estimator's base motion is {est.base_motion!r} (only 'fixed' is compiled)"
        if set(world.legs) != set(LEGS):
            return "the world's legs are not HL, HR, FL, FR"
        return None

    def __init__(self, world, spine, gait) -> None:
        from sparc_quad.bound.step_compiled import control_step

        problem = self.why_not(world, spine, gait)
        if problem is not None:
            raise ValueError(f"no compiled loop: {problem}")
        self.world, self.gait = world, gait
        self._step = control_step
        ctrl, lim, torso_accel = spine.compiled_law()
        self._spine_arrays = ctrl.kernel_arrays()
        gprm, gst, gout, n_gait = gait.kernel_arrays()
        self._gait_arrays = gprm, gst
        self._gait_out = gout
        est = world.estimator
        n_inp = n_gait + sk.X_SIZE
        length = est.delay_line_length
        n_tau = len(world.movable)
        parts = {"inp": n_inp, "qdq": 8, "zacc": 3, "gout": 12, "eprm": sk.E_PRM_SIZE,
                 "est": sk.ES_RING + 3 * length, "lim": sk.L_SIZE, "order": n_tau, "legdq": 12, "tau": n_tau}
        slots = dict(zip(parts, (sk.W_INP, sk.W_QDQ, sk.W_ZACC, sk.W_GOUT, sk.W_EPRM, sk.W_EST, sk.W_LIM,
                                 sk.W_ORDER, sk.W_LEGDQ, sk.W_TAU), strict=True))
        self.ws = ws = np.zeros(sk.W_SIZE + sum(parts.values()))
        self._at: dict[str, int] = {}
        self._size = parts
        o = sk.W_SIZE
        for name, size in parts.items():
            ws[slots[name]] = o
            self._at[name] = o
            o += size
        ws[sk.W_NTAU] = n_tau
        self._part("eprm")[:] = estimator_params(est, torso_accel, world.cfg.slope_rad)
        self._part("lim")[:] = limits_array(lim)
        # the kernel's torque codes: 0-2 the spine, 3 + the place among the bound controller's 12 outputs
        # (LEGS x HAA, HFE, KFE), 15 a joint set to 0
        self._part("order")[:] = [15 if src is None else src[1] if src[0] == "spine"
                                  else 3 + 3 * LEGS.index(src[0]) + src[1] for src in world.torque_sources()]
        pim = world.pos_in_movable
        self._part("legdq")[:] = [pim[j] for k in LEGS for j in world.leg_idx[k]]
        self._pack = struct.Struct(f"{n_inp}d").pack_into
        self.tau = self._part("tau")

    def _part(self, name: str) -> np.ndarray:
        o = self._at[name]
        return self.ws[o:o + self._size[name]]

    def run(self, s: Steps) -> Ended:
        """Steps 0 .. s.n - 1 of this loop's world, spine and gait into `s.log` (rows of COLUMNS; the derived
        columns left as they are), as the Python loop (`bound.python_loop`) runs them."""
        world, gait = self.world, self.gait
        if (s.world, s.gait) != (world, gait):
            raise ValueError("the steps' world and gait are not the ones this loop was built for")
        log, n, stop, stop_on_fall = s.log, s.n, s.stop, s.stop_on_fall
        step, pack, ws, cols = self._step, self._pack, self.ws, _COLS
        sprm, res, sat = self._spine_arrays
        gprm, gst = self._gait_arrays
        at_inp = self._at["inp"]
        tau = self.tau  # len(world.movable): what set_torques makes
        est = self._part("est")
        noise, k = load_estimator(world.estimator, est)
        draw = world.estimator.draw_noise
        set_tau, world_step = world.set_joint_torques, world.step
        w = world
        fell, fall_t, reason = False, None, None
        i = 0
        try:
            while i < n:
                if stop is not None and stop():
                    raise KeyboardInterrupt
                if k == len(noise):
                    noise, k = draw(), 0
                om, cf = w.base_omega, w.contact_force
                pack(ws, 8 * at_inp, w.t, *w.base_pos, w.q1, w.dq1, w.roll, w.yaw, om[0], om[2], *w.q_spine,
                     *w.dq_spine, *w.jq, *w.jdq, cf["HL"], cf["HR"], cf["FL"], cf["FR"], w.body_contact)
                code = step(sprm, res, sat, gprm, gst, ws, cols, noise, k, log, i)
                k += 1
                if code and i and not fell:  # the state after the last step has fallen
                    fell, fall_t, reason = True, w.t, FALL_REASONS[code]
                    if stop_on_fall:
                        break
                set_tau(tau.tolist())
                world_step()
                i += 1
            else:
                if not fell:  # the state after the last step
                    code = sk.fall_code(w.body_contact, w.q1, w.q1 + sum(w.q_spine), w.roll, w.cfg.slope_rad)
                    if code:
                        fell, fall_t, reason = True, w.t, FALL_REASONS[code]
        finally:
            save_estimator(world.estimator, est, noise, k)
            self._gait_out[:] = self._part("gout")  # the controller's own output, as its step leaves it
            gait.take_kernel_state()
        return Ended(i, fell, fall_t, reason)


def estimator_params(est, torso_accel: bool, slope_rad: float) -> np.ndarray:
    """The kernel's E_* parameters of `est` (an `Estimator`), with the spine law's torso-acceleration switch
    and the ground's slope (rad) for the fall test."""
    c = est.cfg
    e = np.zeros(sk.E_PRM_SIZE)
    e[[sk.E_Q1_BIAS, sk.E_Q1_NOISE, sk.E_DQ1_BIAS, sk.E_DQ1_NOISE, sk.E_DDQ1_NOISE, sk.E_DT, sk.E_ALPHA,
       sk.E_LEN, sk.E_TORSO_ACCEL, sk.E_SLOPE]] = (
        c.q1_bias_rad, c.q1_noise_rad, c.dq1_bias_rad_s, c.dq1_noise_rad_s, c.ddq1_noise_rad_s2, est.dt,
        est.accel_filter_alpha, est.delay_line_length, 1.0 if torso_accel else 0.0, slope_rad)
    return e


def limits_array(lim) -> np.ndarray:
    """The kernel's L_* layout of a `spine_module.safety.TorqueLimits` (with a margin: `clear` set)."""
    if lim.clear is None:
        raise ValueError("the compiled output stage needs a joint-limit margin > 0")
    return np.array([*lim.lower, *lim.upper, lim.margin, lim.damping, lim.torque, *lim.clear], dtype=float)


def load_estimator(est, arr: np.ndarray) -> tuple[np.ndarray, int]:
    """Put `est`'s state (`Estimator.save`) into the kernel's ES_* state `arr`; returns its noise block
    (rows of 3) and the next row."""
    noise, k, prev, acc, line = est.save()
    arr[:] = 0.0
    arr[sk.ES_HAS_PREV] = 0.0 if prev is None else 1.0
    arr[sk.ES_PREV_DQ1] = 0.0 if prev is None else prev
    arr[sk.ES_ACC] = acc
    arr[sk.ES_COUNT] = len(line)
    for s, entry in enumerate(line):
        arr[sk.ES_RING + 3 * s:sk.ES_RING + 3 * s + 3] = entry
    return np.array(noise, dtype=float).reshape(-1, 3), k


def save_estimator(est, arr: np.ndarray, noise: np.ndarray, k: int) -> None:
    """Hand the kernel's estimator state back to `est` (`Estimator.restore`): it goes on from there."""
    length = est.delay_line_length
    start, count = int(arr[sk.ES_START]), int(arr[sk.ES_COUNT])
    line = [tuple(arr[sk.ES_RING + 3 * ((start + s) % length):][:3].tolist()) for s in range(count)]
    prev = float(arr[sk.ES_PREV_DQ1]) if arr[sk.ES_HAS_PREV] else None
    est.restore(noise.tolist(), k, prev, float(arr[sk.ES_ACC]), line)
