"""Every step of a bound in Python: the reference loop, and the one that serves what watches each step
(profiling, frames, real time, actuator latency)."""

from __future__ import annotations

import collections
import time

import numpy as np

from sparc_quad.bound.stepping import Ended, Steps, full_step_writer
from sparc_quad.sim.bound_log import LEGS
from sparc_quad.sim.fall import FALL_REASONS, fall_code
from sparc_quad.sim.quadruped_world import QuadWorld

# the phases of a step `Steps.profile` accumulates wall seconds for (time.perf_counter): read
# (world.estimate), spine, gait, log (torques sent, leg states read, log row), physics (world.step:
# stepSimulation + state refresh), other (fall check)
PROFILE_PHASES = ("read", "spine", "gait", "log", "physics", "other")


def fall_reason(world: QuadWorld, pitch_front: float) -> str | None:
    """Why the world's robot has fallen (None: it has not); `sim.fall`'s test on the world's state."""
    return FALL_REASONS[fall_code(world.body_contact, world.q1, pitch_front, world.roll, world.cfg.slope_rad)]


class PythonLoop:
    name = "python"

    def __init__(self, why: str) -> None:
        self.why = why

    def run(self, s: Steps) -> Ended:
        world, spine, gait, n, stop, profile = s.world, s.spine, s.gait, s.n, s.stop, s.profile
        prof = profile is not None
        if prof:
            for key in PROFILE_PHASES:
                profile.setdefault(key, 0.0)
        clock = time.perf_counter
        c0 = c1 = 0.0
        # the per-step calls bound once (the loop's cost is Python's)
        estimate, spine_begin, spine_finish, gait_step = world.estimate, spine.begin, spine.finish, gait.step
        world_step, write, ndarray = world.step, full_step_writer(s), np.ndarray
        latency, realtime, on_frame, frame_every = s.latency, s.realtime, s.on_frame, s.frame_every
        pipe: collections.deque = collections.deque()
        zero_legs = {k: (0.0, 0.0, 0.0) for k in LEGS}
        fell, fall_t, first_reason = False, None, None
        t0 = clock()
        i = 0
        while i < n:
            if stop is not None and stop():
                raise KeyboardInterrupt
            if prof:
                c0 = clock()
            t = world.t
            est = estimate()
            if prof:
                c1 = clock()
                profile["read"] += c1 - c0
            q_sp, dq_sp = world.q_spine, world.dq_spine
            spine_begin(est, q_sp, dq_sp, t)  # a node elsewhere works while the gait runs
            if prof:
                c0 = clock()
                profile["spine"] += c0 - c1
            leg_tau = gait_step(t)
            if prof:
                c1 = clock()
                profile["gait"] += c1 - c0
            tau_s = spine_finish()  # the gait does not read the spine: the order changes no number
            if prof:
                c0 = c1
                c1 = clock()
                profile["spine"] += c1 - c0
            if latency:  # what the actuators apply now was commanded `latency` steps ago
                pipe.append((tuple(tau_s), {k: tuple(v) for k, v in leg_tau.items()}))
                tau_s, leg_tau = pipe.popleft() if len(pipe) > latency else ((0.0, 0.0, 0.0), zero_legs)
            tau_s = tau_s.tolist() if type(tau_s) is ndarray else tau_s  # plain floats: cheaper below
            write(i, t, est, q_sp, dq_sp, tau_s, leg_tau)  # the row logs the state the torques came from
            if frame_every and i % frame_every == 0 and on_frame is not None:
                on_frame(world)
            if prof:
                c0 = clock()
                profile["log"] += c0 - c1
            world_step()
            if prof:
                c1 = clock()
                profile["physics"] += c1 - c0
            if realtime:
                lag = t0 + world.t - time.perf_counter()
                if lag > 0:
                    time.sleep(lag)
            i += 1
            if not fell:  # the first fall's time and reason are kept (stop_on_fall=False runs on)
                reason = fall_reason(world, world.q1 + sum(world.q_spine))
                if reason is not None:
                    fell, fall_t, first_reason = True, world.t, reason
                    if s.stop_on_fall:
                        break
            if prof:
                profile["other"] += clock() - c1
        return Ended(i, fell, fall_t, first_reason)
