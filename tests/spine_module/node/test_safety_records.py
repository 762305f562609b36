"""The node's plain-valued safety step returns one typed record (state fed back + verdict), equal to the
enum-typed `supervise`, and the damping mode's torque is `damping_torque` on plain floats."""

from __future__ import annotations

from spine_module.messages import Fault, Mode
from spine_module.safety import (
    Receipts,
    SafetyConfig,
    SafetyState,
    Supervised,
    damping_torque,
    supervise,
    supervise_values,
)

CFG = SafetyConfig()


def test_supervised_record_matches_supervise_tick_by_tick():
    state, prev, latched = SafetyState(), Supervised(), 0
    for k, (requested, reset) in enumerate([(Mode.IMPEDANCE, False)] * 5 + [(Mode.ESTOP, False)] * 2
                                           + [(Mode.DAMPING, True)] * 3):
        now = 1.0 + k * 0.1
        rx = Receipts(torso=now, feedback=now, command=now, heartbeat=now if k != 3 else 0.0)
        state, verdict = supervise(state, now, rx, requested, reset, CFG)
        prev = supervise_values(prev, now, rx, int(requested), reset, CFG)
        assert isinstance(prev, Supervised)
        assert (prev.latched, prev.mode, prev.ramp_t0, prev.reset_count) == (
            int(state.latched), int(state.mode), state.ramp_t0, state.reset_count)
        assert (prev.faults, prev.gain_scale, prev.default_gains, prev.enable) == (
            int(verdict.faults), verdict.gain_scale, verdict.default_gains, verdict.enable)
        latched |= prev.latched
    assert latched == int(Fault.HEARTBEAT_LOST | Fault.ESTOP) and prev.latched == 0  # latched, then reset
    assert prev.reset_count == 3 and prev.mode == int(Mode.DAMPING)


def test_damping_torque_on_plain_floats():
    assert damping_torque([1.0, -2.0, 0.0], 0.3) == [-0.3, 0.6, -0.0]
