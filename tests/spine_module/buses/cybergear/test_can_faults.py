"""Fault paths of the CAN backend: each ends with stop frames on the wire and the motors stopped.

A silent motor at start-up, a motor that stops answering mid-run, a fault frame, a malformed frame, a send
error, an exception in the control loop, a non-finite command, and SIGTERM (in a child process).

The control loop here stands in for the node's: on MotorBusError it stops the motors (the node's safe
state ends with `bus.stop()` too). Assertions are on frames seen by an independent sniffer on the bus.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import textwrap

import can
import numpy as np
import pytest

from spine_module.buses.base import MotorBusError, MotorCommand
from spine_module.buses.cybergear import CanMotorBus
from spine_module.buses.cybergear import protocol as P
from tests.can_util import rig_config, stops_to, virtual_rig, wait_for
from tests.paths import ROOT


def _control_loop(mb: CanMotorBus, cycles: int = 400, during=None) -> MotorBusError | None:
    """Run like the node: receive, (inject), send; a MotorBusError ends in stop()."""
    try:
        for k in range(cycles):
            mb.receive(timeout_s=0.5)
            if during is not None:
                during(k)
            mb.send(MotorCommand(tau_ff=np.full(3, 0.2), kd=np.full(3, 0.1)))
    except MotorBusError as e:
        mb.stop()
        return e
    return None


def _assert_all_stopped(emu, sniffer, before: dict[int, int], ids=(1, 2, 3)) -> None:
    for i in ids:
        assert wait_for(lambda i=i: stops_to(sniffer, i) > before[i]), f"no stop frame to motor {i}"
        if not emu.motors[i].silent:
            assert wait_for(lambda i=i: emu.motors[i].mode == P.MotorMode.RESET)


def test_silent_motor_at_startup_is_named():
    with virtual_rig() as (channel, emu, sniffer):
        emu.set_silent(2)
        mb = CanMotorBus(rig_config(), interface="virtual", channel=channel)
        with pytest.raises(MotorBusError, match=r"no answer within 0.2 s from motor\(s\) q3 \(CAN id 2\)$"):
            mb.start(timeout_s=0.2)
        mb.shutdown()
        assert all(wait_for(lambda i=i: stops_to(sniffer, i) >= 1) for i in (1, 2, 3))
        assert not emu.frames_of(P.Enable)  # nobody was enabled


def test_motor_that_stops_answering_mid_run():
    with virtual_rig() as (channel, emu, sniffer), \
            CanMotorBus(rig_config(), interface="virtual", channel=channel) as mb:
        mb.start()
        before = {i: stops_to(sniffer, i) for i in (1, 2, 3)}

        def during(k):
            if k == 50:
                emu.set_silent(3)
        err = _control_loop(mb, during=during)
        assert err is not None and "stopped answering: q4 (CAN id 3)" in str(err)
        assert len(emu.frames_of(P.OperationControl, 1)) >= 50
        _assert_all_stopped(emu, sniffer, before)


def test_fault_frame_becomes_node_fault():
    with virtual_rig() as (channel, emu, sniffer), \
            CanMotorBus(rig_config(), interface="virtual", channel=channel) as mb:
        mb.start()
        before = {i: stops_to(sniffer, i) for i in (1, 2, 3)}
        err = _control_loop(mb, during=lambda k: k == 30 and emu.inject_fault(2, fault_value=1 << 3))
        assert err is not None and "fault frame from motor q3 (CAN id 2): overvoltage" in str(err)
        assert mb.fault_report()["q3"]["fault_frame"] == ["overvoltage"]
        _assert_all_stopped(emu, sniffer, before)


def test_feedback_fault_bits_become_node_fault():
    with virtual_rig() as (channel, emu, sniffer), \
            CanMotorBus(rig_config(), interface="virtual", channel=channel) as mb:
        mb.start()
        before = {i: stops_to(sniffer, i) for i in (1, 2, 3)}
        err = _control_loop(mb, during=lambda k: k == 30 and emu.inject_fault(
            1, fault_value=0, feedback_bits=1 << P.FeedbackFault.OVERCURRENT, send_frame=False))
        assert err is not None and "motor q2 (CAN id 1) reports overcurrent" in str(err)
        _assert_all_stopped(emu, sniffer, before)


def test_malformed_frame_from_a_motor():
    with virtual_rig() as (channel, emu, sniffer), \
            CanMotorBus(rig_config(), interface="virtual", channel=channel) as mb:
        mb.start()
        before = {i: stops_to(sniffer, i) for i in (1, 2, 3)}
        err = _control_loop(mb, during=lambda k: k == 20 and emu.send_malformed(2, dlc=5))
        assert err is not None
        assert "malformed frame from motor q3 (CAN id 2): type 2 needs 8 data bytes, got 5" in str(err)
        _assert_all_stopped(emu, sniffer, before)


def test_frames_for_others_are_ignored_not_faults():
    with virtual_rig() as (channel, _emu, _sn), \
            CanMotorBus(rig_config(), interface="virtual", channel=channel) as mb:
        mb.start()
        other = can.Bus(interface="virtual", channel=channel)
        other.send(P.encode_feedback(9, 0xFD, 0, 0, 0, 25))  # a motor we do not drive
        other.send(P.encode_feedback(1, 0x01, 0, 0, 0, 25))  # feedback for another host
        other.send(can.Message(arbitration_id=0x123, data=b"x", is_extended_id=False))
        assert _control_loop(mb, cycles=20) is None
        other.shutdown()
        assert wait_for(lambda: sum(mb.ignored.values()) >= 3)


class _FailingBus(can.BusABC):
    """Wraps a bus; send raises once armed (a full queue or bus-off on a real adapter)."""

    def __init__(self, inner: can.BusABC) -> None:
        self.inner, self.armed, self.channel_info = inner, False, "failing"
        super().__init__(channel="failing")

    def send(self, msg, timeout=None):
        if self.armed and P.split_id(msg.arbitration_id)[0] == P.CommType.OPERATION_CONTROL:
            raise can.CanOperationError("transmit buffer full")
        self.inner.send(msg, timeout)

    def _recv_internal(self, timeout):
        return self.inner.recv(timeout), False

    def shutdown(self):
        self.inner.shutdown()
        super().shutdown()


def test_send_error_is_a_bus_fault_and_stops():
    with virtual_rig() as (channel, emu, sniffer):
        fbus = _FailingBus(can.Bus(interface="virtual", channel=channel))
        with CanMotorBus(rig_config(), bus=fbus) as mb:
            mb.start()
            before = {i: stops_to(sniffer, i) for i in (1, 2, 3)}
            err = _control_loop(mb, during=lambda k: k == 10 and setattr(fbus, "armed", True))
            assert err is not None and "CAN send failed: transmit buffer full" in str(err)
            assert mb.send_errors == 1
            _assert_all_stopped(emu, sniffer, before)
        fbus.shutdown()


def test_exception_in_control_loop_stops_motors():
    with virtual_rig() as (channel, emu, sniffer):
        with pytest.raises(ZeroDivisionError):
            with CanMotorBus(rig_config(), interface="virtual", channel=channel) as mb:
                mb.start()
                before = {i: stops_to(sniffer, i) for i in (1, 2, 3)}
                _control_loop(mb, cycles=10)
                _ = 1 / 0
        _assert_all_stopped(emu, sniffer, before)


def test_non_finite_command_stops_motors():
    with virtual_rig() as (channel, emu, sniffer), \
            CanMotorBus(rig_config(), interface="virtual", channel=channel) as mb:
        mb.start()
        mb.receive(1.0)
        before = {i: stops_to(sniffer, i) for i in (1, 2, 3)}
        with pytest.raises(MotorBusError, match="non-finite"):
            mb.send(MotorCommand(tau_ff=np.array([0.0, np.nan, 0.0])))
        _assert_all_stopped(emu, sniffer, before)


SIGTERM_CHILD = textwrap.dedent("""
    import json, sys, threading, time
    import numpy as np
    from spine_module.buses.base import MotorCommand
    from spine_module.buses.cybergear import CanMotorBus, install_stop_handlers
    from spine_module.buses.cybergear import protocol as P
    from tests.can_util import rig_config, stops_to, virtual_rig, wait_for

    with virtual_rig() as (channel, emu, sniffer):
        mb = CanMotorBus(rig_config(), interface="virtual", channel=channel)
        install_stop_handlers(mb)
        result = {}
        try:
            mb.start()
            before = {i: stops_to(sniffer, i) for i in (1, 2, 3)}
            ticks = 0
            while True:
                mb.receive(0.5)
                mb.send(MotorCommand(tau_ff=np.full(3, 0.2)))
                ticks += 1
                if ticks == 100:
                    print("READY", flush=True)
        except SystemExit as e:
            result["exit"] = e.code
            raise
        finally:
            # the stop frames are sent; wait (on the sniffer, not a guessed time) until it has seen them
            wait_for(lambda: all(stops_to(sniffer, i) > before[i] for i in (1, 2, 3)), timeout_s=30)
            # the emulated motors read the same frames on their own thread: wait for them too (the sniffer
            # seeing a stop does not mean the motor has acted on it yet)
            wait_for(lambda: all(emu.motors[i].mode == P.MotorMode.RESET for i in (1, 2, 3)), timeout_s=30)
            result["new_stops"] = {i: stops_to(sniffer, i) - before[i] for i in (1, 2, 3)}
            result["modes"] = {i: int(emu.motors[i].mode) for i in (1, 2, 3)}
            result["ticks"] = ticks
            mb.shutdown()
            print(json.dumps(result), flush=True)
""")


def test_sigterm_sends_stop_frames(tmp_path):
    script = tmp_path / "child.py"
    script.write_text(SIGTERM_CHILD)
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    proc = subprocess.Popen([sys.executable, str(script)], cwd=ROOT, env=env, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    try:
        line = proc.stdout.readline()
        assert line.strip() == "READY", proc.stderr.read()
        proc.send_signal(signal.SIGTERM)
        out, err = proc.communicate(timeout=30)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 128 + signal.SIGTERM, err
    result = json.loads(out.strip().splitlines()[-1])
    assert result["exit"] == 143 and result["ticks"] >= 100
    assert all(n >= 1 for n in result["new_stops"].values()), result
    assert all(m == P.MotorMode.RESET for m in result["modes"].values()), result


def test_motor_that_will_not_enable_is_named_with_its_fault():
    with virtual_rig() as (channel, emu, sniffer):
        emu.motors[3].stuck_fault_bits = 1 << P.FeedbackFault.NOT_CALIBRATED
        mb = CanMotorBus(rig_config(), interface="virtual", channel=channel)
        with pytest.raises(MotorBusError, match=r"q4 \(CAN id 3\) did not enable within 0.3 s "
                                                r".*q4: mode 0, faults not calibrated"):
            mb.start(timeout_s=0.3)
        mb.shutdown()
        assert all(wait_for(lambda i=i: stops_to(sniffer, i) >= 2) for i in (1, 2, 3))
