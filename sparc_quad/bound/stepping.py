"""The seam between a bound's driver (`bound.run.run_bound`) and the loops that run its steps.

The driver builds the world, the spine and the gait, puts them in `Steps` with the log to fill and the
hooks that watch each step, and hands that to one `StepLoop` (`bound.loops.choose_loop` picks it). The
loop runs the steps, fills one log row per step (all columns but `sim.bound_log.DERIVED`) and says how
the run ended (`Ended`). Every loop gives the same doubles as the Python loop for the same run:

    python_loop.PythonLoop      every step in Python (the reference; profiling, frames, real time, latency)
    held_loop.HeldLoop          Python full steps, the steps between the gait's calls run back to back
    compiled_loop.CompiledLoop  the control half of every step in one compiled call
"""

from __future__ import annotations

import struct
from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from sparc_quad.gaits.base import Gait
from sparc_quad.sim.bound_log import COLUMNS, LEGS
from sparc_quad.sim.quadruped_world import QuadWorld
from sparc_quad.sim.sim_spine import SimSpine

if tuple(LEGS) != ("HL", "HR", "FL", "FR"):
    raise RuntimeError(f"the log row lists the legs HL, HR, FL, FR, got {LEGS}")


@dataclass
class Steps:
    """What a loop steps (world, spine, gait), where it writes (`log`: one row of COLUMNS per step, its
    length the number of steps) and what watches each step."""

    world: QuadWorld
    spine: SimSpine
    gait: Gait
    log: np.ndarray
    stop: Callable[[], bool] | None = None  # asked before each step computed in full; True: KeyboardInterrupt
    stop_on_fall: bool = True
    latency: int = 0  # every joint torque is applied this many steps late
    realtime: bool = False  # pace the steps to the wall clock
    profile: dict[str, float] | None = None  # wall seconds per phase of each step (python_loop)
    on_frame: Callable | None = None  # on_frame(world) every `frame_every` steps
    frame_every: int = 0

    @property
    def n(self) -> int:
        return len(self.log)

    def watched(self) -> str | None:
        """What needs every step in the Python loop (None: nothing)."""
        hooks = (("profiling", self.profile is not None), ("frames", self.frame_every),
                 ("real time", self.realtime), ("actuator latency", self.latency))
        names = [name for name, on in hooks if on]
        return ", ".join(names) or None


@dataclass(frozen=True)
class Ended:
    """How a loop's run ended: rows logged, the first fall (time s, reason) and the steps run in held
    chunks."""

    steps: int
    fell: bool
    fall_t: float | None
    reason: str | None
    held_steps: int = 0


class StepLoop(Protocol):
    name: str  # metrics.json's "loop": python | held | compiled
    why: str  # why `choose_loop` picked it for this run

    def run(self, s: Steps) -> Ended: ...


def full_step_writer(s: Steps) -> Callable:
    """`write(i, t, est, q_sp, dq_sp, tau_s, leg_tau)`, the end of step i computed in full: the torques
    handed to the world, the gait told the spine's task pose, the log row packed. `t`, `est`, `q_sp`,
    `dq_sp` are the state the torques were computed from; `tau_s` a list of plain floats."""
    world, spine, gait, log = s.world, s.spine, s.gait, s.log
    set_torques, observe_spine, flags, leg_dq = world.set_torques, gait.observe_spine, gait.stance_flags, \
        world.leg_rates
    gait_phase, gait_frequency = gait.phase_fraction, gait.frequency
    ndarray = np.ndarray
    # a log row is packed as doubles straight into its place in `log` (PyFloat_AsDouble per value, the same
    # doubles numpy's row assignment makes, without the temporary array)
    row = struct.Struct(f"{len(COLUMNS)}d")
    pack_row, row_bytes = row.pack_into, row.size

    def write(i, t, est, q_sp, dq_sp, tau_s, leg_tau) -> None:
        set_torques(tau_s, leg_tau)
        task = spine.task_pose  # as of this step's begin: read once for the gait and the log
        task = task.tolist() if type(task) is ndarray else task
        observe_spine(t, float(task[0]))
        # the power and peak columns are filled from the logged torques and rates after the loop
        # (metrics.derived_columns)
        q1 = world.q1
        cf = world.contact_force
        pack_row(log, i * row_bytes, t, *world.base_pos, q1, world.dq1, est.q1, est.dq1, est.ddq1,
                 q1 + sum(q_sp), world.roll, world.yaw, *q_sp, *dq_sp, *tau_s,
                 *task, cf["HL"] > 0.0, cf["HR"] > 0.0, cf["FL"] > 0.0, cf["FR"] > 0.0,
                 flags["hind"], flags["front"], 0.0, 0.0, 0.0,
                 *leg_tau["HL"], *leg_tau["HR"], *leg_tau["FL"], *leg_tau["FR"], *leg_dq(),
                 gait_phase(), gait_frequency(), spine.energy_j)

    return write
