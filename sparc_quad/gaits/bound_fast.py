"""`CompiledBoundController`: the bound controller of `gaits.bound` with its step in the numba kernel
(`gaits.bound_kernel`, compiled by `gaits.bound_compiled`); the Python `BoundController` is the reference."""

from __future__ import annotations

import struct

import numpy as np

from sparc_quad.gaits.base import Gait
from sparc_quad.gaits.bound import BoundController
from sparc_quad.gaits.bound_kernel import I_JQ, S_DUTY, S_PHASE, S_PITCH, S_STANCE_F, S_STANCE_H, pack


class CompiledBoundController(Gait):
    """`BoundController` with its step in the compiled kernel: same constructor, `step(t)`, `out`,
    `stance_flags`, `phase`, `duty`, `pitch`. Raises RuntimeError where numba cannot load the kernel."""

    backend = "numba"

    def __init__(self, world, params=None):
        try:
            from sparc_quad.gaits.bound_compiled import bound_step as fn
        except Exception as exc:  # ImportError, or numba failing to compile/load here
            raise RuntimeError(f"the compiled bound controller needs a working numba: {exc}") from exc
        self.reference = ref = BoundController(world, params)
        self.p, self.w, self.legs, self.PAIRS = ref.p, world, ref.legs, ref.PAIRS
        self._fn = fn
        self._prm, self._st = pack(ref)
        self._inp = np.zeros(I_JQ + 2 * len(world.movable))
        # the inputs packed as doubles into `_inp` (a struct, not numpy's sequence conversion: half the cost)
        self._pack_inp = struct.Struct(f"{len(self._inp)}d").pack_into
        self._out = np.zeros(12)
        self.out = dict(ref.out)
        self.stance_flags = dict(ref.stance_flags)
        self.phase, self.duty, self.pitch = ref.phase, ref.duty, 0.0

    def phase_fraction(self) -> float:
        return self.phase

    def frequency(self) -> float:
        return self.p.frequency_hz

    def step(self, t: float) -> dict[str, tuple[float, float, float]]:
        w = self.w
        om = w.base_omega
        self._pack_inp(self._inp, 0, t, *w.base_pos, w.q1, w.dq1, w.roll, w.yaw, om[0], om[2], *w.q_spine,
                       *w.dq_spine, *w.jq, *w.jdq)
        self._fn(self._prm, self._st, self._inp, self._out)
        return self.take_kernel_state()

    def kernel_arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
        """(prm, st, out, how many inputs) of the kernel `bound_kernel.bound_step`: what the bound's compiled
        step steps in place of `step` (then `take_kernel_state`)."""
        return self._prm, self._st, self._out, len(self._inp)

    def take_kernel_state(self) -> dict[str, tuple[float, float, float]]:
        """`out`, `stance_flags`, `phase`, `duty` and `pitch` from the kernel's arrays after its step (here,
        or in the bound's compiled step, which steps `_prm`, `_st` and `_out` itself)."""
        st = self._st
        o = self._out.tolist()
        out = self.out
        out["HL"], out["HR"], out["FL"], out["FR"] = (o[0], o[1], o[2]), (o[3], o[4], o[5]), \
            (o[6], o[7], o[8]), (o[9], o[10], o[11])
        s = st.tolist()
        self.phase, self.duty, self.pitch = s[S_PHASE], s[S_DUTY], s[S_PITCH]
        flags = self.stance_flags
        flags["hind"], flags["front"] = s[S_STANCE_H] > 0.5, s[S_STANCE_F] > 0.5
        return out
