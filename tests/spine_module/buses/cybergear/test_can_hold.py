"""From enable to the node's first command the backend keeps the motors fed with zero-torque frames, so a
node that needs longer than the motors' CAN timeout to reach its first tick does not trip them."""

from __future__ import annotations

import numpy as np
import pytest

from spine_module.buses.base import MotorCommand
from spine_module.buses.cybergear import CanMotorBus, load_config
from spine_module.buses.cybergear import driver as D
from spine_module.buses.cybergear import protocol as P
from tests.can_util import stops_to, virtual_rig, wait_for


def _type1(sn, motor_id: int) -> list:
    return [P.decode_to_motor(m) for m in sn.of_type(P.CommType.OPERATION_CONTROL, motor_id)]


@pytest.mark.parametrize("torque_mode", ["operation", "current"])
def test_zero_torque_frames_keep_the_shipped_can_timeout_from_tripping(torque_mode):
    """The emulator's clock is moved by the test: 30 ms (under the shipped 50 ms timeout) per batch of
    frames the backend sends by itself, 20 times (600 ms): no motor trips, all stay in RUN; without the
    frames the first 50 ms would trip them (and the node would latch "left run mode")."""
    t = [0.0]
    cfg = load_config().with_(torque_mode=torque_mode, silent_timeout_s=0.5)
    assert cfg.can_timeout_s == 0.05
    with virtual_rig(lockstep=False, clock=lambda: t[0]) as (channel, emu, sn):
        with CanMotorBus(cfg, interface="virtual", channel=channel) as mb:
            mb.start()
            for k in range(20):  # a frame the emulator took at the current time, then 30 ms on
                assert wait_for(lambda: all(m.last_rx_s == t[0] for m in emu.motors.values())), k
                t[0] += 0.03
                emu.check_can_timeouts()
            assert emu.timeout_trips == [] and all(m.mode == P.MotorMode.RUN for m in emu.motors.values())
            if torque_mode == "operation":
                assert all(abs(f.torque) < 1e-3 and f.kp == 0 and f.kd == 0 for f in _type1(sn, 1))
            assert mb.hold_frames_sent >= 3 * 19  # a batch per step after the first (the enables)
            # the node's first command ends the hold and drives with no fault latched
            mb.send(MotorCommand(tau_ff=np.full(3, 0.5)))
            assert mb.receive(1.0) is not None and mb.latched_faults == []
            held = mb.hold_frames_sent
            for _ in range(5):
                mb.send(MotorCommand(tau_ff=np.full(3, 0.5)))
                assert mb.receive(1.0) is not None
            assert mb.hold_frames_sent == held


def test_hold_ends_by_stopping_the_motors_when_no_command_comes(monkeypatch):
    """A node that never starts controlling gets its motors stopped after hold_max_s; its first command
    then enables them again without a fault."""
    with virtual_rig(lockstep=False) as (channel, emu, sn):
        with CanMotorBus(load_config().with_(silent_timeout_s=0.5), interface="virtual", channel=channel,
                         hold_max_s=0.05) as mb:
            mb.start()
            assert wait_for(lambda: all(stops_to(sn, i) >= 2 for i in (1, 2, 3)))  # start-up's + the hold's
            assert wait_for(lambda: all(m.mode == P.MotorMode.RESET for m in emu.motors.values()))
            mb.send(MotorCommand(tau_ff=np.full(3, 0.2)))
            assert mb.receive(1.0) is not None and mb.latched_faults == []
            assert wait_for(lambda: all(m.mode == P.MotorMode.RUN for m in emu.motors.values()))


def test_no_hold_for_lockstep_rigs():
    with virtual_rig() as (channel, _emu, sn):
        with CanMotorBus(load_config().with_(silent_timeout_s=0.5), interface="virtual", channel=channel,
                         hold_max_s=0.0) as mb:
            mb.start()
            assert not wait_for(lambda: sn.of_type(P.CommType.OPERATION_CONTROL), timeout_s=0.1)
            assert mb.hold_frames_sent == 0 and D.HOLD_MAX_S > 0
