"""Issue 31, motor side: a bad, doubled or lost motor latches a named bus fault and stops every motor.

Each case injects on a private virtual CAN channel (an extra python-can bus plays the glitching encoder,
the second motor on one id, the stray host) while the emulated motors answer the backend as in the node's
loop. Assertions: the fault is latched (`latched_faults`, every later `receive` raises), the bad values never
reach a returned feedback, stop frames go to every motor, and no torque frame follows the latch.
"""

from __future__ import annotations

import can
import numpy as np
import pytest

from sparc_quad.sim.cybergear_emulator import CyberGearEmulator
from spine_module.buses.base import MotorBusError, MotorCommand, MotorSetupError
from spine_module.buses.cybergear import CanMotorBus
from spine_module.buses.cybergear import protocol as P
from tests.can_util import rig_config, stops_to, virtual_rig, wait_for

HOST = rig_config().host_id


def _drive(mb: CanMotorBus, cycles: int, during=None) -> tuple[MotorBusError | None, list[np.ndarray]]:
    """The node's loop: receive, (inject), send a small torque; returns the error that ended it and every q
    the backend returned."""
    qs = []
    try:
        for k in range(cycles):
            fb = mb.receive(timeout_s=0.5)
            if fb is not None:
                qs.append(fb.q.copy())
            if during is not None:
                during(k)
            mb.send(MotorCommand(tau_ff=np.full(3, 0.05), kd=np.full(3, 0.1)))
    except MotorBusError as e:
        return e, qs
    return None, qs


def _caught_up(mb: CanMotorBus, sniffer) -> None:
    """Wait until the sniffer has every frame the backend sent so far (a marker after them, same sender)."""
    marker = can.Message(arbitration_id=0x7FF, data=b"mark", is_extended_id=False)
    n = sum(1 for m in list(sniffer.frames) if m.arbitration_id == 0x7FF and not m.is_extended_id)
    mb.bus.send(marker)
    assert wait_for(lambda: sum(1 for m in list(sniffer.frames)
                                if m.arbitration_id == 0x7FF and not m.is_extended_id) > n)


def _after_latch_only_stops(mb: CanMotorBus, sniffer, ids=(1, 2, 3)) -> None:
    """The node keeps ticking after a latch: each send must become stop frames, never a torque frame."""
    _caught_up(mb, sniffer)
    n_ctrl = len(sniffer.of_type(P.CommType.OPERATION_CONTROL))
    before = {i: stops_to(sniffer, i) for i in ids}
    for _ in range(5):
        with pytest.raises(MotorBusError):
            mb.receive(0.0)
        with pytest.raises(MotorBusError):
            mb.send(MotorCommand(tau_ff=np.full(3, 1.0)))
    _caught_up(mb, sniffer)
    assert all(stops_to(sniffer, i) >= before[i] + 5 for i in ids)
    assert len(sniffer.of_type(P.CommType.OPERATION_CONTROL)) == n_ctrl


@pytest.mark.parametrize("motor,position,velocity,expect", [
    (1, 2.0, 0.0, "implausible feedback from motor q2 (CAN id 1): position 2 rad outside"),  # +2 rad glitch
    (2, 1.0, 0.0, "implausible feedback from motor q3 (CAN id 2): position jumped "),  # inside range
    (2, 0.0, 29.0, "implausible feedback from motor q3 (CAN id 2): velocity jumped "),  # velocity spike
    (3, 0.0, 30.0, "implausible feedback from motor q4 (CAN id 3): velocity 30 rad/s at the frame's"),
])
def test_implausible_feedback_latches_and_never_reaches_the_node(motor, position, velocity, expect):
    with virtual_rig() as (channel, _emu, sniffer), \
            CanMotorBus(rig_config(), interface="virtual", channel=channel) as mb:
        glitch = can.Bus(interface="virtual", channel=channel)
        mb.start()
        frame = P.encode_feedback(motor, HOST, position, velocity, 0.0, 30.0, P.MotorMode.RUN, 0)
        err, qs = _drive(mb, 200, during=lambda k: k == 50 and glitch.send(frame))
        glitch.shutdown()
        assert err is not None and expect in str(err), err
        assert any(expect in f for f in mb.latched_faults)
        assert 50 <= len(qs) <= 52
        assert all(abs(q[motor - 1] - position) > 0.5 or position == 0.0 for q in qs)
        _after_latch_only_stops(mb, sniffer)


class _SweepLoad:
    """Motor 2 (q3) accelerates at 5000 rad/s^2 to 25 rad/s and cruises, one step per lockstep cycle."""

    def __init__(self) -> None:
        self.q, self.dq = 0.0, 0.0

    def read(self, motor_id: int) -> tuple[float, float]:
        return (self.q, self.dq) if motor_id == 2 else (0.0, 0.0)

    def step(self, torques: dict[int, float], dt: float) -> None:
        if self.q < 2.8:
            self.dq = min(self.dq + 5000.0 * dt, 25.0)
            self.q += self.dq * dt


def test_plausible_motion_at_top_speed_is_no_fault():
    """The bounds are not tighter than the motor: q3 swept at up to 25 rad/s, 5000 rad/s^2."""
    load = _SweepLoad()
    with virtual_rig(load=load) as (channel, _emu, _sniffer), \
            CanMotorBus(rig_config(), interface="virtual", channel=channel) as mb:
        mb.start()
        err, qs = _drive(mb, 200)
        assert err is None and mb.latched_faults == []
        assert max(q[1] for q in qs) > 2.7 and load.dq == 25.0


def test_two_motors_on_one_id_refuse_to_start():
    with virtual_rig() as (channel, _emu, sniffer):
        twin_bus = can.Bus(interface="virtual", channel=channel)
        twin = CyberGearEmulator(twin_bus, (2,), lockstep=True)
        twin.motors[2].uid = bytes.fromhex("c6b0000000dead02")
        mb = CanMotorBus(rig_config(), interface="virtual", channel=channel)
        try:
            with pytest.raises(MotorSetupError, match=r"two motors answer as one id: CAN id 2 \(q3\): MCU "
                                                      r"uids c6b0000000001002, c6b0000000dead02"):
                mb.start()
            assert all(wait_for(lambda i=i: stops_to(sniffer, i) >= 1) for i in (1, 2, 3))
        finally:
            mb.shutdown()
            twin.shutdown()
            twin_bus.shutdown()


def test_unexpected_uid_mid_run_latches():
    with virtual_rig() as (channel, _emu, sniffer), \
            CanMotorBus(rig_config(), interface="virtual", channel=channel) as mb:
        stray = can.Bus(interface="virtual", channel=channel)
        mb.start()
        reply = P.encode_device_id(2, bytes.fromhex("c6b0000000dead02"))
        err, _ = _drive(mb, 200, during=lambda k: k == 40 and stray.send(reply))
        stray.shutdown()
        assert err is not None and "q3 (CAN id 2): a get-id reply from MCU uid c6b0000000dead02" in str(err)
        _after_latch_only_stops(mb, sniffer)


def test_lost_motor_stays_latched_when_it_answers_again():
    with virtual_rig() as (channel, emu, sniffer), \
            CanMotorBus(rig_config(), interface="virtual", channel=channel) as mb:
        mb.start()
        err, _ = _drive(mb, 400, during=lambda k: k == 30 and emu.set_silent(3))
        assert err is not None and "stopped answering: q4 (CAN id 3)" in str(err)
        assert any("stopped answering: q4 (CAN id 3)" in f for f in mb.latched_faults)
        emu.set_silent(3, False)  # it comes back, in RUN or not: never driven again before start()
        _after_latch_only_stops(mb, sniffer)


def test_motors_answering_another_host_latch():
    with virtual_rig() as (channel, emu, sniffer), \
            CanMotorBus(rig_config(), interface="virtual", channel=channel) as mb:
        mb.start()

        def rehome(k):
            if k == 30:
                with emu.lock:
                    emu.host_id = 0x01  # every reply now goes to another host: this one hears nothing
        err, _ = _drive(mb, 400, during=rehome)
        assert err is not None and "stopped answering" in str(err)
        assert mb.latched_faults
        with emu.lock:
            emu.host_id = HOST
        _after_latch_only_stops(mb, sniffer)


def test_motor_outside_its_range_at_start_up_refuses():
    with virtual_rig() as (channel, emu, _sniffer):
        emu.load.q[1] = 1.0  # q2's range is [-1.75, 0.2] rad: 0.8 rad beyond it, margin 0.3
        mb = CanMotorBus(rig_config(), interface="virtual", channel=channel)
        try:
            with pytest.raises(MotorBusError, match=r"implausible feedback at start-up: q2 \(CAN id 1\): "
                                                    r"position \S+ rad outside \[-2.05, 0.5\]"):
                mb.start()
        finally:
            mb.shutdown()


def test_motor_answering_with_another_motors_id_latches():
    """Motor 3 starts answering as id 2 (a mis-set id): its own id goes silent, which latches. (Emulator
    answering at once, not in lockstep, whose step waits for every motor id it knows.)"""
    with virtual_rig(lockstep=False) as (channel, emu, sniffer), \
            CanMotorBus(rig_config(), interface="virtual", channel=channel) as mb:
        mb.start()

        def rename(k):
            if k == 30:
                with emu.lock:
                    emu.motors[3].can_id = 2  # the emulator still routes its frames; its replies say 2
        err, _ = _drive(mb, 400, during=rename)
        assert err is not None and "stopped answering: q4 (CAN id 3)" in str(err)
        assert any("q4 (CAN id 3)" in f for f in mb.latched_faults)
        _after_latch_only_stops(mb, sniffer)
