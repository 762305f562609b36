"""Safety with real motors: joints map by name, motors.toml is checked field by field, the motors' CAN
timeout is written and read back (refusing to run without it), and our own stop never reads as a fault."""

from __future__ import annotations

import time

import can
import numpy as np
import pytest

from spine_module.buses.base import MotorCommand
from spine_module.buses.cybergear import CanMotorBus, load_config
from spine_module.buses.cybergear import protocol as P
from spine_module.buses.cybergear.config import DEFAULT_CONFIG_PATH, ConfigError
from tests.can_util import rig_config, virtual_rig, wait_for

BASE = DEFAULT_CONFIG_PATH.read_text()
JOINTS = {"q2": 1, "q3": 2, "q4": 3}


def _toml(bus: str = "", joints: list[tuple[str, int]] | None = None, joint_extra: str = "") -> str:
    joints = list(JOINTS.items()) if joints is None else joints
    text = "[bus]\nhost_id = 0xFD\n" + bus + "\n"
    for name, cid in joints:
        text += f'[[joint]]\nname = "{name}"\ncan_id = {cid}\n{joint_extra}\n'
    return text


def test_joints_listed_out_of_order_route_by_name(tmp_path):
    """A file listing q4, q3, q2 (ids 3, 2, 1): each joint's torque still reaches its own CAN id."""
    path = tmp_path / "motors.toml"
    path.write_text(_toml(joints=[("q4", 3), ("q3", 2), ("q2", 1)]))
    cfg = load_config(path).with_(silent_timeout_s=0.5)
    assert [j.name for j in cfg.joints] == ["q2", "q3", "q4"] and cfg.ids == (1, 2, 3)
    path.write_text(_toml(joints=[("q4", 1), ("q2", 3), ("q3", 2)]))  # q4 wired to id 1, q2 to id 3
    cfg = load_config(path).with_(silent_timeout_s=0.5)
    with virtual_rig() as (channel, emu, _sn), CanMotorBus(cfg, interface="virtual", channel=channel) as mb:
        mb.start()
        mb.receive(1.0)
        mb.send(MotorCommand(tau_ff=np.array([1.0, 2.0, 3.0])))  # q2, q3, q4
        assert mb.receive(1.0) is not None
        got = {i: emu.frames_of(P.OperationControl, i)[-1].torque for i in (1, 2, 3)}
    assert got == pytest.approx({3: 1.0, 2: 2.0, 1: 3.0}, abs=1e-3)


@pytest.mark.parametrize("text,needle", [
    (_toml(joints=[("q2", 1), ("q3", 2)]), "no entry for joint q4"),
    (_toml(joints=[("q2", 1), ("q3", 2), ("q4", 3), ("q5", 4)]), "unknown joint 'q5'"),
    (_toml(joints=[("q2", 1), ("q3", 2), ("q3", 3)]), "joint q3 listed more than once"),
    (_toml(joints=[("q2", 1), ("q3", 2), ("Q4", 3)]), "unknown joint 'Q4'"),
    (_toml(bus="silent_timeout_s = nan"), "[bus].silent_timeout_s must be finite"),
    (_toml(bus="silent_timeout_s = -1.0"), "silent_timeout_s must be a finite number > 0"),
    (_toml(bus="limit_torque_nm = inf"), "[bus].limit_torque_nm must be finite"),
    (_toml(bus="can_timeout_s = -0.02"), "can_timeout_s must be a finite number >= 0"),
    (_toml(bus="can_timeout_s = 10.0"), "can_timeout_s must be <= 5 s"),
    (_toml(bus="silent_timout_s = 0.1"), "[bus]: unknown key 'silent_timout_s'"),
    (_toml(bus='rate_hz = "fast"'), "[bus].rate_hz must be a number"),
    (_toml(joint_extra="gear_ratio = -2.0"), "gear_ratio and torque_scale must be > 0"),
    (_toml(joint_extra="zero_offset_rad = nan"), "zero_offset_rad must be finite"),
    (_toml(joint_extra="directon = -1"), "unknown key 'directon'"),
    (_toml() + "[[joint]]\ncan_id = 4\n", "[[joint]] #4: missing 'name'"),
    ('[bus]\n[joint]\nname = "q2"\ncan_id = 1\n', "[joint] is a single table: write each joint as [[joint]]"),
    ("[bus]\nhost_id = \n", "not valid TOML"),
    (_toml() + "[buss]\n", "unknown table or key 'buss'"),
])
def test_bad_motor_config_names_file_and_field(tmp_path, text, needle):
    path = tmp_path / "motors.toml"
    path.write_text(text)
    with pytest.raises(ConfigError) as e:
        load_config(path)
    assert str(path) in str(e.value) and needle in str(e.value), str(e.value)


def test_missing_motor_config_file(tmp_path):
    with pytest.raises(ConfigError, match=r"nosuch\.toml: cannot read the motor config"):
        load_config(tmp_path / "nosuch.toml")


@pytest.mark.parametrize("argv", [["motors", "status"], ["spine-node", "--motors", "can", "--duration", "0.1",
                                                         "--lcm-url", "memq://"]])
def test_cli_bad_motor_config_exits_2_without_traceback(tmp_path, argv, capsys, caplog):
    from sparc_quad.cli import main

    path = tmp_path / "motors.toml"
    path.write_text(_toml(bus="silent_timeout_s = nan"))
    rc = main([*argv, "--can-interface", "virtual",
               "--motor-config", str(path)])
    out = capsys.readouterr()
    assert rc == 2
    text = out.err + caplog.text
    assert "silent_timeout_s" in text and str(path) in text and "Traceback" not in text


def test_can_timeout_written_read_back_and_refused_when_missing():
    """Start-up writes CAN_TIMEOUT (0x200C) and reads it back; a firmware that does not keep it (here an
    emulated motor that ignores the write) makes start() refuse, naming the motor, with motors stopped."""
    with virtual_rig() as (channel, emu, _sn):
        with CanMotorBus(rig_config(can_timeout_s=0.03), interface="virtual", channel=channel) as mb:
            mb.start()
            assert mb.can_timeout_confirmed == {"q2": 600, "q3": 600, "q4": 600}
            assert all(emu.motors[i].params["CAN_TIMEOUT"] == 600 for i in (1, 2, 3))
        original = emu._write_param

        def forgetful(m, spec, value):  # motor 2 acknowledges CAN_TIMEOUT writes but keeps 0
            original(m, spec, 0 if (m.can_id == 2 and spec.name == "CAN_TIMEOUT") else value)
        emu._write_param = forgetful
        with CanMotorBus(rig_config(can_timeout_s=0.03), interface="virtual", channel=channel) as mb:
            with pytest.raises(Exception, match=r"could not set the motors' CAN timeout.*q3 \(CAN id 2\): "
                                                r"read back 0"):
                mb.start()
        assert all(m.mode == P.MotorMode.RESET for m in emu.motors.values())


def _all_commanded(emu, torque_nm: float, since: int) -> bool:
    """Every emulated motor has handled an operation frame of `torque_nm` among its frames from `since`."""
    with emu.lock:
        got = {f.motor_id for f in emu.received[since:]
               if isinstance(f, P.OperationControl) and abs(f.torque - torque_nm) < 1e-3}
    return got == set(emu.motors)


def test_emulated_can_timeout_stops_a_motor_on_its_own_clock():
    """The emulator's CAN timeout: a RUN motor with no frame for CAN_TIMEOUT drops to zero torque, on the
    emulator's clock (a fake one here); with CAN_TIMEOUT = 0 (the firmware default) it runs on forever."""
    t = [0.0]
    with virtual_rig(lockstep=False, clock=lambda: t[0]) as (channel, emu, _sn):
        for timeout_s, expect_stop in ((0.0, False), (0.03, True)):
            cfg = rig_config(can_timeout_s=timeout_s, can_timeout_off=timeout_s == 0)
            with CanMotorBus(cfg, interface="virtual", channel=channel) as mb:
                mb.start()
                assert mb.receive(1.0) is not None
                with emu.lock:
                    n_before = len(emu.received)
                mb.send(MotorCommand(tau_ff=np.full(3, 0.5)))
                # this send's own frames, not the 0.5 N·m the first case left in the motors: those frames
                # set the clock the timeout counts from
                assert wait_for(lambda n0=n_before: _all_commanded(emu, 0.5, since=n0))
                emu.step()
                assert all(m.last_torque == pytest.approx(0.5, abs=1e-3) for m in emu.motors.values())
                t[0] += 0.0299
                emu.step()
                assert all(m.mode == P.MotorMode.RUN for m in emu.motors.values())
                t[0] += 0.0002
                emu.step()
                stopped = [m.mode == P.MotorMode.RESET and m.last_torque == 0.0 for m in emu.motors.values()]
                assert all(stopped) if expect_stop else not any(stopped)
                mb._notifier.stop()  # the "killed" host sends no stop frames on exit
                mb._closed = True
            if expect_stop:
                trips = [(i, round(t1 - t0, 4)) for i, t0, t1 in emu.timeout_trips]
                assert trips == [(1, 0.0301), (2, 0.0301), (3, 0.0301)]


class _SlowSendBus(can.BusABC):
    """A python-can bus whose send takes `delay_s` (a slow USB adapter): the motors' replies to the first
    stop frames arrive while the later ones are still being sent."""

    def __init__(self, channel: str, delay_s: float) -> None:
        self.inner = can.Bus(interface="virtual", channel=channel)
        self.delay_s = delay_s
        self.channel_info = "slow virtual"
        super().__init__(channel=channel)

    def send(self, msg, timeout=None):
        self.inner.send(msg, timeout)
        time.sleep(self.delay_s)

    def _recv_internal(self, timeout):
        return self.inner.recv(timeout), False

    def shutdown(self):
        self.inner.shutdown()
        super().shutdown()


def test_own_stop_reply_is_not_a_fault_and_motors_run_again():
    """The race of `_send_stops`: with a 2 ms send, every stop's RESET reply arrives before the last stop
    frame is out. It must not latch 'left run mode'; enabling again drives the motors with no fault."""
    with virtual_rig(lockstep=False) as (channel, emu, _sn):
        bus = _SlowSendBus(channel, 0.002)
        mb = CanMotorBus(rig_config(), bus=bus)
        try:
            mb.start()
            for _ in range(5):
                for _ in range(3):
                    mb.send(MotorCommand(tau_ff=np.full(3, 0.1)))
                    assert mb.receive(1.0) is not None
                mb.send(MotorCommand.zero())  # enable=False: stop frames
                assert wait_for(lambda: all(m.mode == P.MotorMode.RESET for m in emu.motors.values()))
                assert mb.receive(1.0) is not None
                assert mb.latched_faults == []
            mb.send(MotorCommand(tau_ff=np.full(3, 0.1)))
            assert mb.receive(1.0) is not None and mb.latched_faults == []
            assert wait_for(lambda: all(m.mode == P.MotorMode.RUN for m in emu.motors.values()))
        finally:
            mb.shutdown()
            bus.shutdown()
