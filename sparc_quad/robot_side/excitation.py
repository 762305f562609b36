"""An identification experiment for the bench: what a lab runs before `sparc-quad gap run` on its log.

The static push-pull moves the spine slowly along x only: q4 barely moves, accelerations are small, so
rotor inertia and viscous friction are weakly excited. Here the torso computer commands the impedance
target along a sum of sines on each task axis (x, z, theta: disjoint harmonics of one base frequency, so
the three joints move with different spectra), with its velocity and acceleration as feed-forward, while the
rig pushes along x with a sine of its own period (the load cell's reading is the trial's external force).
Every joint then reverses many times (Coulomb, Stribeck), spans its speed range (viscous) and accelerates
(rotor inertia), at loads up to the push's.

Limits: the target stays within `max_offset` of the equilibrium pose (x +-0.03 m, z +-0.03 m, theta
+-0.25 rad by default, well inside the joint limits of params.JOINT_*_RAD), speeds under the CyberGear's
range; the excitation fades in over `fade_s` after the node's soft start and out before the end, so the
run starts and ends at rest at the equilibrium.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from sparc_quad.robot_side.scripts import BenchScript
from sparc_quad.sim.forces import push_pull
from spine_module import params as P
from spine_module.messages import Mode, SpineCommand

# harmonics of the base frequency per task axis (x, z, theta): disjoint, so each axis has its own lines
HARMONICS = ((1, 4, 7, 10), (2, 5, 8, 11), (3, 6, 9, 12))
IDENT_DURATION_S = 20.0  # robot time of the default run (s): 4.5 periods of the 0.25 Hz base line


@dataclass(frozen=True)
class Excitation:
    """Sums of sines on the task target. `base_hz` the lowest line (Hz; the highest is 12 x it),
    `max_offset` (m, m, rad) the largest excursion from the equilibrium pose per axis, `push_n` the rig's
    push amplitude (N) at `push_period_s`, `start_s` the wait for the soft start, `fade_s` the ramp."""

    base_hz: float = 0.25
    max_offset: tuple[float, float, float] = (0.03, 0.03, 0.25)
    push_n: float = 2.0
    push_period_s: float = 2.7
    start_s: float = 1.0
    fade_s: float = 1.0

    def __post_init__(self) -> None:
        if not 0 < self.base_hz <= 1.0:
            raise ValueError(f"base frequency {self.base_hz} Hz outside (0, 1] (its 12th line must stay "
                             "under the spine's 12 Hz impedance bandwidth)")
        if not all(0 <= a <= m for a, m in zip(self.max_offset, (0.04, 0.04, 0.3), strict=True)):
            raise ValueError(f"offsets {self.max_offset} beyond (0.04 m, 0.04 m, 0.3 rad)")
        if not 0 <= self.push_n <= 10.0:
            raise ValueError(f"push {self.push_n} N outside [0, 10]")
        object.__setattr__(self, "_lines", self._make_lines())

    def lines(self) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
        """Per axis (frequencies Hz, amplitudes, phases rad); computed once (`_make_lines`)."""
        return self._lines

    def _make_lines(self) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
        """Per axis (frequencies Hz, amplitudes, phases rad): equal velocity per line (amplitude ~ 1/f),
        Schroeder phases (low crest factor), scaled so the sum's peak is the axis's max offset."""
        out = []
        for axis, harm in enumerate(HARMONICS):
            f = self.base_hz * np.array(harm, float)
            a = 1.0 / f
            n = len(f)
            phase = -math.pi * np.arange(1, n + 1) * np.arange(n) / n + 0.5 * math.pi * axis
            t = np.linspace(0.0, 1.0 / self.base_hz, 4000, endpoint=False)
            peak = np.max(np.abs(np.sin(2 * math.pi * np.outer(t, f) + phase) @ a))
            out.append((f, a * self.max_offset[axis] / peak, phase))
        return out

    def envelope(self, t: float, duration_s: float) -> tuple[float, float, float]:
        """Fade in after start_s and out before the end: (w, dw/dt, d2w/dt2), a quintic smoothstep
        (10x^3 - 15x^4 + 6x^5: the target's acceleration has no step where the fade starts or ends)."""
        up = (t - self.start_s) / self.fade_s
        down = (duration_s - t) / self.fade_s
        x = min(up, down)
        if x <= 0:
            return 0.0, 0.0, 0.0
        if x >= 1:
            return 1.0, 0.0, 0.0
        s = 1.0 if up <= down else -1.0
        w = x**3 * (10 - 15 * x + 6 * x**2)
        dw = s * 30 * x**2 * (1 - x) ** 2 / self.fade_s
        ddw = 60 * x * (1 - x) * (1 - 2 * x) / self.fade_s**2
        return w, dw, ddw

    def target(self, t: float, duration_s: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Task target (x m, z m, theta rad), its velocity and acceleration at robot time t (s)."""
        w, dw, ddw = self.envelope(t, duration_s)
        x = P.X_EQUILIBRIUM.copy()
        dx = np.zeros(3)
        ddx = np.zeros(3)
        for axis, (f, a, ph) in enumerate(self.lines()):
            om = 2 * math.pi * f
            s = float(np.sum(a * np.sin(om * t + ph)))
            ds = float(np.sum(a * om * np.cos(om * t + ph)))
            dds = float(np.sum(-a * om**2 * np.sin(om * t + ph)))
            x[axis] += w * s
            dx[axis] = dw * s + w * ds
            ddx[axis] = ddw * s + 2 * dw * ds + w * dds
        return x, dx, ddx


def ident_script(duration_s: float = IDENT_DURATION_S, excitation: Excitation | None = None,
                 k: tuple[float, float, float] = tuple(P.K_DEFAULT),
                 d: tuple[float, float, float] = tuple(P.D_DEFAULT)) -> BenchScript:
    """The identification experiment as a robot-side script: impedance mode along `excitation`'s target
    (with feed-forward) and the rig's push; `duration_s` of robot time."""
    ex = excitation if excitation is not None else Excitation()
    if duration_s < ex.start_s + 2 * ex.fade_s + 1.0:
        raise ValueError(f"an identification run of {duration_s:g} s is too short: it needs the soft start "
                         f"({ex.start_s:g} s), the fades (2 x {ex.fade_s:g} s) and excitation in between")
    kk, dd = np.array(k, float), np.array(d, float)

    def command(t: float) -> SpineCommand:
        x, dx, ddx = ex.target(t, duration_s)
        return SpineCommand(mode=Mode.IMPEDANCE, x_d=x, dx_d=dx, ddx_d=ddx, k=kk.copy(), d=dd.copy())

    push = push_pull(ex.push_n, ex.push_period_s) if ex.push_n > 0 else None
    return BenchScript(command=command, force=push, duration_s=duration_s)
