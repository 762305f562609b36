"""The gap workflow reads an `lcm-logger` file of a spine-node session directly.

- A real session: `spine-node` and `bench-robot` as separate processes on UDP multicast in a network
  namespace, recorded by `lcm-logger` (the harness of
  `tests/integration/test_node_lcm_netns.py`, reused as is); the
  log loads as a trial whose columns are exactly the spine states the node published.
- Hand-made logs: a truncated, a wrong-fingerprint and a non-finite spine state are each rejected with an
  error naming the file and the event number; unrelated channels are skipped.
"""

from __future__ import annotations

import json

import lcm
import numpy as np
import pytest

from sparc_quad.gap.trial import TrialError, load_lcm_log, load_trial
from sparc_quad.gap.workflow import load_trials
from spine_module import params as P
from spine_module.messages import SpineState, TorsoState, channels, codec
from tests.node_netns import PERIOD, logger_loss_allowance, unshare_prefix

needs_netns = pytest.mark.skipif(unshare_prefix() is None, reason="cannot create a network namespace here")


@needs_netns
@pytest.mark.netns
def test_recorded_session_loads_as_trial(lcm_run):
    out, logs = lcm_run
    log = out / "session.lcmlog"
    a = np.load(out / "bench_robot.npz")  # the spine states the robot received from the node
    tr = load_lcm_log(log)  # no sidecar: the bench spine (q1 fixed at 0)
    n = round(PERIOD * 1000)
    assert tr.robot.joints == ["q2", "q3", "q4"] and tr.robot.actuated == ["q2", "q3", "q4"]
    assert tr.rate_hz == P.CONTROL_RATE_HZ
    # one row per control tick, 1 ms apart (a state datagram the logger missed, rare, is filled in)
    assert len(tr.t) == n, logs
    np.testing.assert_allclose(np.diff(tr.t), 1e-3, rtol=1e-9)
    filled = np.isin(tr.t, tr.meta["source"]["filled_t"])
    allowed = logger_loss_allowance(out, n)
    assert filled.sum() <= allowed
    # every recorded row is, field for field, the state the robot received from the node (by stamp,
    # should the robot or the logger have missed a datagram)
    rows = {float(s): i for i, s in enumerate(a["node_stamp_s"])}
    mine = [i for i in range(n) if not filled[i] and float(tr.t[i]) in rows]
    assert len(mine) >= n - filled.sum() - (n - len(rows))  # all but those the logger or the robot lacks
    theirs = [rows[float(tr.t[i])] for i in mine]
    np.testing.assert_array_equal(tr.q[mine], a["node_q"][theirs, 1:])
    np.testing.assert_array_equal(tr.dq[mine], a["node_dq"][theirs, 1:])
    np.testing.assert_array_equal(tr.tau_cmd[mine], a["node_tau_cmd"][theirs])
    np.testing.assert_array_equal(tr.tau_meas[mine], a["node_tau_est"][theirs])
    np.testing.assert_array_equal(tr.f_ext[mine, 0], a["node_load_cell"][theirs, 0])
    assert not np.any(tr.f_ext[:, 1:]) and np.ptp(tr.f_ext[:, 0]) > 1.0  # the push-pull is in the log
    assert np.max(np.abs(tr.tau_cmd)) > 0.1  # the node was controlling, not idle
    # the states in the log and the ones filled in make the whole session (a loaded machine's logger can
    # miss a few: 3 of 2000 seen)
    assert tr.meta["source"]["spine_states"] + int(filled.sum()) == n, logs
    # the same file through the workflow's loader, and with a sidecar that keeps q1 (from the torso state)
    assert len(load_trials([log])[0].t) == n
    side = log.with_name("q1free.json")
    meta = json.loads(json.dumps({**tr.meta, "fixed_joints": {}}))
    meta.pop("source")
    meta["urdf"] = str((log.parent / meta["urdf"]).resolve())
    side.write_text(json.dumps(meta))
    log_copy = log.with_name("q1free.lcmlog")
    log_copy.write_bytes(log.read_bytes())
    tr4 = load_trial(log_copy)
    assert tr4.robot.joints == ["q1", "q2", "q3", "q4"]
    np.testing.assert_array_equal(tr4.q[mine], a["node_q"][theirs])


def _state(k: int) -> SpineState:
    s = SpineState(stamp_s=k * 1e-3, seq=k, q=P.Q_EQUILIBRIUM + 0.01 * k, dq=np.full(4, 0.1 * k),
                   tau_cmd=np.array([0.1, -0.2, 0.3]) * k, tau_est=np.array([0.1, -0.2, 0.3]) * k + 0.01,
                   load_cell=np.array([2.0 * k, np.nan]))
    return s


def _write(path, events) -> None:
    log = lcm.EventLog(str(path), "w", overwrite=True)
    for k, (channel, data) in enumerate(events):
        log.write_event(1_000_000 + 1000 * k, channel, data)
    log.close()


def _good_events(n: int = 20):
    ev = [("LCM_SELF_TEST", b"\x00garbage")]
    for k in range(n):
        ev.append((channels.TORSO_STATE, codec.encode_torso(TorsoState(stamp_s=k * 1e-3, seq=k))))
        ev.append((channels.SPINE_STATE, codec.encode_state(_state(k))))
        ev.append(("SOMEONE_ELSES_CHANNEL", b"\x01\x02"))
    return ev


def test_hand_made_log_columns(tmp_path):
    p = tmp_path / "hand.lcm"
    _write(p, _good_events())
    tr = load_lcm_log(p)
    k = np.arange(20)
    np.testing.assert_allclose(tr.t, k * 1e-3)
    np.testing.assert_allclose(tr.q, P.Q_EQUILIBRIUM[1:] + 0.01 * k[:, None])
    np.testing.assert_allclose(tr.tau_cmd, np.array([0.1, -0.2, 0.3]) * k[:, None])
    np.testing.assert_allclose(tr.tau_meas, tr.tau_cmd + 0.01)
    np.testing.assert_allclose(tr.f_ext[:, 0], 2.0 * k)
    assert tr.meta["source"]["events"] == 1 + 3 * 19 + 2


@pytest.mark.parametrize("kind", ["truncated", "fingerprint", "nan_q", "mode"])
def test_corrupted_event_is_named(tmp_path, kind):
    ev = _good_events()
    bad_index = 3 * 7 + 2  # 0-based: the 8th spine state; event number bad_index + 1
    good = ev[bad_index][1]
    if kind == "truncated":
        ev[bad_index] = (channels.SPINE_STATE, good[:-5])
        match = r"malformed sparc\.spine_state_t"
    elif kind == "fingerprint":
        ev[bad_index] = (channels.SPINE_STATE, codec.encode_torso(TorsoState()))
        match = r"wrong fingerprint.*expected sparc\.spine_state_t.*got a sparc\.torso_state_t"
    elif kind == "nan_q":
        s = _state(7)
        s.q[2] = np.nan
        ev[bad_index] = (channels.SPINE_STATE, codec.encode_state(s))
        match = r"q\[2\] \(q3\) is nan"
    else:
        raw = codec.decode_raw(channels.SPINE_STATE, good)
        raw.mode = 77
        ev[bad_index] = (channels.SPINE_STATE, raw.encode())
        match = "77"
    p = tmp_path / f"{kind}.lcm"
    _write(p, ev)
    with pytest.raises(TrialError, match=match) as info:
        load_lcm_log(p)
    msg = str(info.value)
    assert msg.startswith(str(p)) and f"event {bad_index + 1}" in msg, msg


def test_bad_event_on_other_sparc_channel_and_empty_log(tmp_path):
    ev = _good_events()
    ev[4] = (channels.SPINE_COMMAND, b"\x00" * 12)  # not a spine command
    p = tmp_path / "cmd.lcm"
    _write(p, ev)
    with pytest.raises(TrialError, match=r"event 5 \(channel 'SPARC_SPINE_COMMAND'"):
        load_lcm_log(p)
    p2 = tmp_path / "empty.lcm"
    _write(p2, [("LCM_SELF_TEST", b"x")])
    with pytest.raises(TrialError, match="no SPARC_SPINE_STATE events"):
        load_lcm_log(p2)


def test_broken_framing_is_named_and_cut_tail_is_tolerated(tmp_path, caplog):
    p = tmp_path / "frame.lcm"
    _write(p, _good_events(60))
    b = p.read_bytes()
    cut = tmp_path / "cut.lcm"  # the logger interrupted in its last write
    cut.write_bytes(b[:-30])
    tr = load_lcm_log(cut)
    assert len(tr.t) == 60 and tr.meta["source"]["unread_tail_bytes"] > 0
    assert "not a whole event" in caplog.text
    bad = tmp_path / "sync.lcm"  # a garbled sync word early in the file: the rest is unreadable
    at = b.index(b"\xed\xa1\xda\x01", 200)  # the first event header from byte 200 (messages' sizes vary)
    bad.write_bytes(b[:at] + b"\xff" * 8 + b[at + 8:])
    with pytest.raises(TrialError, match=r"event \d+: invalid LCM event header at byte \d+"):
        load_lcm_log(bad)


def test_lost_states_filled_in_and_long_gap_refused(tmp_path, caplog):
    ev = _good_events()
    lost = {3 * 5 + 2, 3 * 6 + 2}  # spine states k = 5 and 6 never reached the logger
    p = tmp_path / "lost.lcm"
    _write(p, [e for i, e in enumerate(ev) if i not in lost])
    tr = load_lcm_log(p)
    k = np.arange(20)
    np.testing.assert_allclose(tr.t, k * 1e-3)
    np.testing.assert_allclose(tr.q, P.Q_EQUILIBRIUM[1:] + 0.01 * k[:, None])  # linear: exact
    assert tr.meta["source"]["filled_t"] == pytest.approx([0.005, 0.006])
    assert "2 spine state(s) missing" in caplog.text
    long_gap = {3 * j + 2 for j in range(4, 11)}  # 7 in a row
    p2 = tmp_path / "gap.lcm"
    _write(p2, [e for i, e in enumerate(ev) if i not in long_gap])
    with pytest.raises(TrialError, match=r"7 spine states missing between seq 3 \(event \d+\) and 11"):
        load_lcm_log(p2)
