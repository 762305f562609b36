"""Held steps: a bound whose gait and spine hold their outputs between the gait's control calls.

After a step computed in full, the engine runs it and the steps up to the gait's next call (the authors'
clock) back to back with the controls as they are (`world.step_chunk`: MuJoCo keeps the raw states); the
estimator, the spine and the gait's clock then catch up on those states in order and the loop packs the
rest of their rows (`aux`). A spine torque that changed in a chunk rewinds the world to that step, which
then runs in full. The held rows are completed after the loop (`fill_held_rows`). Same numbers as the
Python loop at every step (tests/integration/sim/test_held_steps.py).
"""

from __future__ import annotations

import struct

import numpy as np

from sparc_quad.bound.stepping import Ended, Steps, full_step_writer
from sparc_quad.sim.bound_log import COLUMNS, DERIVED
from sparc_quad.sim.fall import FALL_REASONS, fall_code
from sparc_quad.sim.quadruped_world import HELD_STATE, QuadWorld

# A held step's log row: the world packs HELD_STATE; the loop packs HELD_AUX (after the index of the row whose
# torques and stance the step holds); HELD_KEPT is copied from that row; the power and peak columns are
# derived after the loop, as for every row.
HELD_AUX = ("t", "q1_true", "dq1_true", "roll", "yaw", "q1_est", "dq1_est", "ddq1_est", "pitch_front",
            "spine_x", "spine_z", "spine_theta", "gait_phase", "gait_frequency_hz", "spine_spring_energy_j")
HELD_KEPT = ("tau2", "tau3", "tau4", "stance_hind", "stance_front",
             *(c for c in COLUMNS if c.startswith("tau_")))
if sorted((*HELD_STATE, *HELD_AUX, *HELD_KEPT, *DERIVED)) != sorted(COLUMNS):
    raise RuntimeError("a held step's row must cover every log column once (held_loop.HELD_*)")
_COL = {c: k for k, c in enumerate(COLUMNS)}
_HELD_STATE_COLS = [_COL[c] for c in HELD_STATE]
_HELD_AUX_COLS = [_COL[c] for c in HELD_AUX]
_HELD_KEPT_COLS = [_COL[c] for c in HELD_KEPT]


def fill_held_rows(series: np.ndarray, world: QuadWorld, aux: np.ndarray) -> None:
    """Complete the held steps' rows of `series` in place: `aux[:, 0]` is the index of the row each holds
    (-1: a row the loop packed in full), `aux[:, 1:]` its HELD_AUX values, `world.held_rows` its
    HELD_STATE values."""
    rows = np.flatnonzero(aux[:, 0] >= 0.0)
    if not len(rows):
        return
    src = aux[rows, 0].astype(np.intp)
    series[np.ix_(rows, _HELD_STATE_COLS)] = world.held_rows(rows)
    series[np.ix_(rows, _HELD_AUX_COLS)] = aux[rows, 1:]
    series[np.ix_(rows, _HELD_KEPT_COLS)] = series[np.ix_(src, _HELD_KEPT_COLS)]


class HeldLoop:
    name = "held"

    @staticmethod
    def why_not(s: Steps) -> str | None:
        """Why `s` cannot run in held chunks (None: it can)."""
        if s.watched():
            return f"{s.watched()} needs every step"
        if not s.world.can_rewind:
            return f"the {s.world.engine} world cannot rewind part of a chunk"
        if s.gait.clock is None:
            return "the gait has no control clock (it acts every step)"
        if not s.spine.clocked:  # a node spine's torque moves every step and would rewind every chunk
            return "the spine's torque may change every step (no control clock of its own)"
        return None

    def __init__(self, why: str) -> None:
        self.why = why

    def run(self, s: Steps) -> Ended:
        world, spine, gait, log, n, stop = s.world, s.spine, s.gait, s.log, s.n, s.stop
        world.start_held(n + 1)  # row i: the state before step i
        aux = np.full((n, 1 + len(HELD_AUX)), -1.0)
        pack_aux = struct.Struct(f"{1 + len(HELD_AUX)}d").pack_into
        aux_bytes = 8 * (1 + len(HELD_AUX))
        estimate, spine_begin, spine_finish, gait_step = world.estimate, spine.begin, spine.finish, gait.step
        est_update, step_chunk, rewind = world.estimator.update, world.step_chunk, world.rewind
        idle_ticks, gait_phase, gait_frequency = gait.clock.idle_ticks, gait.phase_fraction, gait.frequency
        write, ndarray, slope = full_step_writer(s), np.ndarray, world.cfg.slope_rad
        fell, fall_t, first_reason = False, None, None
        pending = None  # a step whose estimator, spine and gait ran in a chunk's catch-up: its full path
        i = 0
        while i < n:
            if stop is not None and stop():
                raise KeyboardInterrupt
            if pending is not None:
                t, est, q_sp, dq_sp, leg_tau, tau_s = pending
                pending = None
            else:
                t = world.t
                est = estimate()
                q_sp, dq_sp = world.q_spine, world.dq_spine
                spine_begin(est, q_sp, dq_sp, t)
                leg_tau = gait_step(t)
                tau_s = spine_finish()
            tau_s = tau_s.tolist() if type(tau_s) is ndarray else tau_s
            write(i, t, est, q_sp, dq_sp, tau_s, leg_tau)
            # this step and the held ones up to the gait's next call, then their catch-up
            k = min(1 + idle_ticks(), n - i)
            s0 = j = i
            for t1, q1, dq1, roll, yaw, q_sp1, dq_sp1, body, twist in step_chunk(k, i):
                # the state after step j: its fall check, then (inside the chunk) step j + 1's catch-up
                pf1 = q1 + sum(q_sp1)
                if not fell:
                    reason = FALL_REASONS[fall_code(body, q1, pf1, roll, slope)]
                    if reason is not None:
                        fell, fall_t, first_reason = True, t1, reason
                        if s.stop_on_fall:
                            break
                j += 1
                if j == s0 + k:
                    break
                est = est_update(q1, dq1, twist)
                spine_begin(est, q_sp1, dq_sp1, t1)
                leg_tau = gait_step(t1)
                tau_s1 = spine_finish()
                if not (type(tau_s1) is list and tau_s1 == tau_s):  # the spine's torque changed
                    rewind(j - s0)
                    pending = (t1, est, q_sp1, dq_sp1, leg_tau, tau_s1)
                    break
                task = spine.task_pose
                task = task.tolist() if type(task) is ndarray else task
                pack_aux(aux, j * aux_bytes, s0, t1, q1, dq1, roll, yaw, est.q1, est.dq1, est.ddq1,
                         pf1, *task, gait_phase(), gait_frequency(), spine.energy_j)
            if fell and s.stop_on_fall:
                i = j + 1
                break
            i = j
        fill_held_rows(log[:i], world, aux[:i])
        return Ended(i, fell, fall_t, first_reason, held_steps=int((aux[:i, 0] >= 0.0).sum()))
