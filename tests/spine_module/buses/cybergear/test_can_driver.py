"""CanMotorBus against the emulator on python-can's `virtual` bus: handshake, torque modes, conversions,
configuration file, session logging."""

from __future__ import annotations

import dataclasses

import can
import numpy as np
import pytest

from spine_module.buses.base import MotorCommand
from spine_module.buses.cybergear import CanMotorBus, JointConfig, load_config
from spine_module.buses.cybergear import protocol as P
from spine_module.buses.cybergear.config import DEFAULT_CONFIG_PATH, KT_NM_PER_A
from tests.can_util import rig_config, virtual_rig, wait_for


def _bus(channel, cfg=None, **kw):
    return CanMotorBus(cfg or rig_config(), interface="virtual", channel=channel, **kw)


def test_default_config_file():
    cfg = load_config(DEFAULT_CONFIG_PATH)
    assert [j.name for j in cfg.joints] == ["q2", "q3", "q4"] and cfg.ids == (1, 2, 3)
    assert cfg.host_id == 0xFD and cfg.torque_mode == "operation"
    assert cfg.kt_nm_per_a == pytest.approx(KT_NM_PER_A, abs=1e-4)


def test_config_file_is_user_editable(tmp_path):
    text = DEFAULT_CONFIG_PATH.read_text().replace('torque_mode = "operation"', 'torque_mode = "current"')
    text = text.replace("[bus]\n", '[bus]\nposition_max_rad = "4pi"\n')
    path = tmp_path / "motors.toml"
    path.write_text(text)
    cfg = load_config(path)
    assert cfg.torque_mode == "current" and cfg.position_max_rad == pytest.approx(4 * np.pi)
    path.write_text(text.replace("can_id = 2", "can_id = 1"))
    with pytest.raises(ValueError, match="duplicate CAN ids"):
        load_config(path)
    with pytest.raises(ValueError, match="direction"):
        JointConfig("q2", 1, direction=2)


def test_handshake_and_pure_torque_operation_control():
    with virtual_rig() as (channel, emu, sniffer):
        with _bus(channel) as mb:
            mb.start()
            for i in (1, 2, 3):
                kinds = [type(f) for f in emu.frames_of(P.Frame, i)]
                assert kinds[:7] == [P.GetId, P.Stop, P.ParamWrite, P.ParamWrite, P.ParamWrite, P.ParamRead,
                                     P.Enable]  # run_mode, limit_torque, CAN_TIMEOUT (+ its read-back)
                assert emu.motors[i].params["CAN_TIMEOUT"] == round(0.5 * P.CAN_TIMEOUT_TICKS_PER_S)
                assert emu.frames_of(P.Stop, i)[0].clear_fault
                assert emu.motors[i].mode == P.MotorMode.RUN and emu.motors[i].params["run_mode"] == 0
            fb = mb.receive(1.0)
            assert fb is not None and list(fb.mode) == [2, 2, 2]
            mb.send(MotorCommand(tau_ff=np.array([1.0, -2.0, 3.0])))
            fb = mb.receive(1.0)
            for i, t in zip((1, 2, 3), (1.0, -2.0, 3.0), strict=True):
                cmd = emu.frames_of(P.OperationControl, i)[-1]
                assert cmd.kp == 0.0 and cmd.kd == 0.0 and cmd.torque == pytest.approx(t, abs=24 / 65535)
            assert fb.tau == pytest.approx([1.0, -2.0, 3.0], abs=1e-3)
            assert fb.dq[2] > 0 > fb.dq[1]  # the free load accelerated with the torques' signs
        assert all(emu.motors[i].mode == P.MotorMode.RESET for i in (1, 2, 3))  # stopped on exit
        assert wait_for(lambda: all(len(sniffer.of_type(P.CommType.STOP, i)) >= 2 for i in (1, 2, 3)))


def test_direction_offset_and_gains_reach_the_motor():
    base = rig_config()
    joints = (dataclasses.replace(base.joints[0], direction=-1, zero_offset_rad=0.5),
              base.joints[1], dataclasses.replace(base.joints[2], gear_ratio=2.0))
    cfg = dataclasses.replace(base, joints=joints)
    with virtual_rig() as (channel, emu, _sn), _bus(channel, cfg) as mb:
        emu.load.q.update({1: 0.3, 2: -0.2, 3: 1.0})
        mb.start()
        fb = mb.receive(1.0)
        assert fb.q == pytest.approx([-(0.3 - 0.5), -0.2, 0.5], abs=1e-3)
        mb.send(MotorCommand(tau_ff=np.array([1.0, 1.0, 1.0]), q_des=np.array([0.1, 0.1, 0.1]),
                             dq_des=np.zeros(3), kp=np.full(3, 20.0), kd=np.full(3, 1.0)))
        mb.receive(1.0)
        c1, c3 = emu.frames_of(P.OperationControl, 1)[-1], emu.frames_of(P.OperationControl, 3)[-1]
        assert c1.torque == pytest.approx(-1.0, abs=1e-3) and c1.position == pytest.approx(0.4, abs=1e-3)
        assert c1.kp == pytest.approx(20.0, abs=0.01) and c1.kd == pytest.approx(1.0, abs=1e-3)
        assert c3.torque == pytest.approx(0.5, abs=1e-3) and c3.position == pytest.approx(0.2, abs=1e-3)
        assert c3.kp == pytest.approx(5.0, abs=0.01) and c3.kd == pytest.approx(0.25, abs=1e-3)


def test_current_mode_torque_control():
    cfg = rig_config(torque_mode="current")
    with virtual_rig() as (channel, emu, _sn), _bus(channel, cfg) as mb:
        mb.start()
        assert all(emu.motors[i].params["run_mode"] == P.RunMode.CURRENT for i in (1, 2, 3))
        assert not emu.refused
        fb = mb.receive(1.0)
        mb.send(MotorCommand(tau_ff=np.array([1.23, 0.0, -4.0]), q_des=fb.q + 0.1, kp=np.array([0, 10.0, 0]),
                             kd=np.zeros(3)))
        mb.receive(1.0)
        writes = {i: [f for f in emu.frames_of(P.ParamWrite, i) if f.index == 0x7006][-1].value
                  for i in (1, 2, 3)}
        assert writes[1] == pytest.approx(1.23 / cfg.kt_nm_per_a, rel=1e-5)
        assert writes[2] == pytest.approx(10 * 0.1 / cfg.kt_nm_per_a, rel=1e-3)  # PD closed on the host
        assert writes[3] == pytest.approx(-4.0 / cfg.kt_nm_per_a, rel=1e-5)
        assert emu.motors[1].torque(0, 0, cfg.kt_nm_per_a) == pytest.approx(1.23, rel=1e-5)
        assert not emu.frames_of(P.OperationControl)


def test_disable_sends_stop_and_reenable(tmp_path):
    with virtual_rig() as (channel, emu, _sniffer), _bus(channel) as mb:
        mb.start()
        mb.receive(1.0)
        mb.send(MotorCommand.zero(3, enable=False))
        assert mb.receive(1.0) is not None
        assert all(emu.motors[i].mode == P.MotorMode.RESET for i in (1, 2, 3))
        mb.send(MotorCommand(tau_ff=np.zeros(3)))
        fb = mb.receive(1.0)
        assert wait_for(lambda: all(emu.motors[i].mode == P.MotorMode.RUN for i in (1, 2, 3)))
        assert fb is not None


@pytest.mark.parametrize("suffix", [".asc", ".blf"])
def test_session_log(tmp_path, suffix):
    path = tmp_path / f"session{suffix}"
    with virtual_rig() as (channel, _emu, _sn):
        with _bus(channel, log_path=path) as mb:
            mb.start()
            for _ in range(5):
                mb.receive(1.0)
                mb.send(MotorCommand(tau_ff=np.full(3, 0.1)))
        frames = list(can.LogReader(str(path)))
    kinds = {P.split_id(m.arbitration_id)[0] for m in frames}
    assert {0, 1, 2, 3, 4, 18} <= kinds  # get id, control, feedback, enable, stop, parameter write
    assert sum(1 for m in frames if P.split_id(m.arbitration_id)[0] == 1) == 15
    assert sum(1 for m in frames if P.split_id(m.arbitration_id)[0] == 4) >= 6


def test_bus_load_is_accounted_on_construction(caplog):
    with virtual_rig() as (channel, _emu, _sn):
        with caplog.at_level("WARNING"), _bus(channel) as mb:
            assert mb.load.frames_per_s == 6000 and mb.load.utilisation_worst == pytest.approx(0.96)
        assert "exceeds 80 %" in caplog.text


def test_stats_and_emulated_speed_and_position_modes():
    with virtual_rig() as (channel, emu, _sn), _bus(channel) as mb:
        mb.start()
        st = mb.stats()
        assert st["tx_frames"] == 21 and st["rx_frames"] >= 21  # 7 frames per motor in the handshake
    m = emu.motors[1]
    m.mode = P.MotorMode.RUN
    m.params.update(run_mode=P.RunMode.SPEED, spd_ref=2.0, spd_kp=1.0, limit_cur=5.0)
    assert m.torque(0.0, 0.0) == pytest.approx(2.0 * KT_NM_PER_A)
    assert m.torque(0.0, 10.0) == pytest.approx(-5.0 * KT_NM_PER_A)  # current-limited
    m.params.update(run_mode=P.RunMode.POSITION, loc_ref=1.0, limit_spd=0.5)
    assert m.torque(0.0, 0.0) == pytest.approx(0.5 * KT_NM_PER_A)  # speed-limited approach
    assert m.torque(1.0, 0.0) == 0.0


def test_blf_log_survives_channel_names_with_large_numbers(tmp_path):
    from spine_module.buses.cybergear.driver import _SessionLog
    log = _SessionLog(tmp_path / "x.blf")
    log.on_message_received(can.Message(arbitration_id=P.make_id(2, 0x8001, 0xFD), data=bytes(8),
                                        channel="test-8a93b71234"))
    log.stop()
    (frame,) = list(can.LogReader(str(tmp_path / "x.blf")))
    assert frame.arbitration_id == P.make_id(2, 0x8001, 0xFD)
