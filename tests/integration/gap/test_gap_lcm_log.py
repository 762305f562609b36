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

from sparc_quad.gap import lcm_log
from sparc_quad.gap.trial import TrialError, load_lcm_log, load_lcm_segments
from sparc_quad.gap.workflow import load_trials
from spine_module import params as P
from spine_module.messages import SpineState, TorsoState, channels, codec
from tests.node_netns import PERIOD, logger_loss_allowance, unshare_prefix

needs_netns = pytest.mark.skipif(unshare_prefix() is None, reason="cannot create a network namespace here")


@needs_netns
@pytest.mark.netns
def test_recorded_session_loads_as_trial(lcm_run):
    """Every spine state the logger recorded is a trial row, field for field as the node published it; a
    state datagram lost alone or a few in a row is filled in, a longer run of them (a loaded machine's
    logger: 7 in a row seen) splits the log into segments that load as trials, the gaps listed."""
    out, logs = lcm_run
    log = out / "session.lcmlog"
    a = np.load(out / "bench_robot.npz")  # the spine states the robot received from the node
    # no sidecar: the bench spine (q1 fixed at 0); every piece kept, however short, to compare all rows
    segs = load_lcm_segments(log, min_segment_s=0.0)
    n = round(PERIOD * 1000)
    tr = segs[0]
    assert tr.robot.joints == ["q2", "q3", "q4"] and tr.robot.actuated == ["q2", "q3", "q4"]
    assert tr.rate_hz == P.CONTROL_RATE_HZ
    gaps = tr.meta["source"]["gaps"]
    assert len(segs) == len(gaps) + 1 and all(s.meta["source"]["gaps"] == gaps for s in segs)
    assert all(g["lost"] > lcm_log.MAX_FILL_TICKS for g in gaps)
    for s in segs:  # one row per control tick inside a segment, 1 ms apart
        np.testing.assert_allclose(np.diff(s.t), 1e-3, rtol=1e-9)
    t = np.concatenate([s.t for s in segs])
    filled = np.isin(t, np.concatenate([s.meta["source"]["filled_t"] for s in segs]))
    lost_in_gaps = sum(g["lost"] for g in gaps)
    # states the logger missed at the very start or end leave no gap (the node's ticks are seq 0..n-1)
    lost_at_edges = segs[0].meta["source"]["first_seq"] + (n - 1 - segs[-1].meta["source"]["last_seq"])
    # the rows, the states lost in the gaps or at the edges and nothing else make the whole session
    assert len(t) + lost_in_gaps + lost_at_edges == n, (gaps, logs)
    assert int(filled.sum()) + lost_in_gaps + lost_at_edges <= logger_loss_allowance(out, n), (gaps, logs)
    assert sum(s.meta["source"]["spine_states"] for s in segs) + int(filled.sum()) == len(t)

    def cat(name):
        return np.concatenate([getattr(s, name) for s in segs])

    q, dq, tau, est, f = cat("q"), cat("dq"), cat("tau_cmd"), cat("tau_meas"), cat("f_ext")
    # every recorded row is, field for field, the state the robot received from the node (by stamp,
    # should the robot also have missed a datagram)
    rows = {float(x): i for i, x in enumerate(a["node_stamp_s"])}
    mine = [i for i in range(len(t)) if not filled[i] and float(t[i]) in rows]
    assert len(mine) >= len(t) - filled.sum() - (n - len(rows))
    theirs = [rows[float(t[i])] for i in mine]
    np.testing.assert_array_equal(q[mine], a["node_q"][theirs, 1:])
    np.testing.assert_array_equal(dq[mine], a["node_dq"][theirs, 1:])
    np.testing.assert_array_equal(tau[mine], a["node_tau_cmd"][theirs])
    np.testing.assert_array_equal(est[mine], a["node_tau_est"][theirs])
    np.testing.assert_array_equal(f[mine, 0], a["node_load_cell"][theirs, 0])
    assert not np.any(f[:, 1:]) and np.ptp(f[:, 0]) > 1.0  # the push-pull is in the log
    assert np.max(np.abs(tau)) > 0.1  # the node was controlling, not idle
    assert tr.meta["lacks"] == [] and tr.meta["columns"]["f_ext_x"].startswith("SPARC_SPINE_STATE.load_cell")
    # the workflow's loader takes every segment of at least MIN_SEGMENT_S
    longest = max(len(s.t) for s in segs)
    if longest >= lcm_log.MIN_SEGMENT_S * 1000:
        kept = load_trials([log])
        assert sum(len(k.t) for k in kept) == sum(len(s.t) for s in segs if len(s.t) >= 1000)
    # with a sidecar that keeps q1 (from the torso state)
    side = log.with_name("q1free.json")
    meta = json.loads(json.dumps({**tr.meta, "fixed_joints": {}}))
    for key in ("source", "columns", "lacks"):
        meta.pop(key)
    meta["urdf"] = str((log.parent / meta["urdf"]).resolve())
    side.write_text(json.dumps(meta))
    log_copy = log.with_name("q1free.lcmlog")
    log_copy.write_bytes(log.read_bytes())
    segs4 = load_lcm_segments(log_copy, min_segment_s=0.0)
    assert segs4[0].robot.joints == ["q1", "q2", "q3", "q4"]
    assert "torso state" in segs4[0].meta["columns"]["q_q1"]
    np.testing.assert_array_equal(np.concatenate([s.q for s in segs4])[mine], a["node_q"][theirs])


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


def test_lost_states_filled_in_and_long_gap_splits(tmp_path, caplog):
    ev = _good_events()
    lost = {3 * 5 + 2, 3 * 6 + 2}  # spine states k = 5 and 6 never reached the logger
    p = tmp_path / "lost.lcm"
    _write(p, [e for i, e in enumerate(ev) if i not in lost])
    tr = load_lcm_log(p)
    k = np.arange(20)
    np.testing.assert_allclose(tr.t, k * 1e-3)
    np.testing.assert_allclose(tr.q, P.Q_EQUILIBRIUM[1:] + 0.01 * k[:, None])  # linear: exact
    assert tr.meta["source"]["filled_t"] == pytest.approx([0.005, 0.006])
    assert tr.meta["source"]["gaps"] == []
    assert "2 spine state(s) missing" in caplog.text
    ev = _good_events(60)
    long_gap = {3 * j + 2 for j in range(24, 31)}  # states 24..30: 7 in a row
    p2 = tmp_path / "gap.lcm"
    _write(p2, [e for i, e in enumerate(ev) if i not in long_gap])
    segs = load_lcm_segments(p2, min_segment_s=0.01)
    assert [len(s.t) for s in segs] == [24, 29]
    np.testing.assert_allclose(segs[1].t, np.arange(31, 60) * 1e-3)
    np.testing.assert_allclose(segs[1].q, P.Q_EQUILIBRIUM[1:] + 0.01 * np.arange(31, 60)[:, None])
    gap = segs[0].meta["source"]["gaps"]
    assert gap == [{"after_seq": 23, "before_seq": 31, "lost": 7, "t0_s": 0.023, "t1_s": 0.031,
                    "event": gap[0]["event"]}]
    assert segs[0].name != segs[1].name and all(s.meta["source"]["segments"] == 2 for s in segs)
    assert "7 spine states missing between seq 23 and 31" in caplog.text
    # a piece shorter than the minimum is dropped and listed; the rest still loads
    segs = load_lcm_segments(p2, min_segment_s=0.025)
    assert [len(s.t) for s in segs] == [29]
    assert segs[0].meta["source"]["dropped_segments"][0]["last_seq"] == 23
    # only a log with no piece long enough is refused, saying so
    with pytest.raises(TrialError, match=r"too little left to identify: 1 gap\(s\).*at most 0\.028 s"):
        load_lcm_segments(p2)
    # one Trial from a split log is an error that points to the segments
    with pytest.raises(TrialError, match=r"2 segments.*load_lcm_segments"):
        lcm_log.load(p2, min_segment_s=0.01)


def test_log_says_what_it_lacks_and_where_columns_come_from(tmp_path, caplog):
    ev = _good_events(30)
    for i, (ch, data) in enumerate(ev):
        if ch == channels.SPINE_STATE:
            s = codec.decode(ch, data)
            s.load_cell = np.array([np.nan, np.nan])
            s.tau_est = np.full(3, np.nan) if s.seq == 4 else s.tau_est
            ev[i] = (ch, codec.encode_state(s))
    p = tmp_path / "bare.lcm"
    _write(p, ev)
    tr = load_lcm_log(p)
    assert tr.f_ext is None and tr.tau_meas is None
    lacks = " ".join(tr.meta["lacks"])
    assert "f_ext: SPARC_SPINE_STATE.load_cell[0] is NaN in 30 of 30" in lacks and "tau_meas" in lacks
    assert "load_cell[0] is NaN" in caplog.text
    cols = tr.meta["columns"]
    assert cols["tau_cmd_q3"].startswith("SPARC_SPINE_STATE.tau_cmd[1]") and "f_ext_x" not in cols
    # a load cell read every other tick: filled in, said so
    ev = _good_events(30)
    for i, (ch, data) in enumerate(ev):
        if ch == channels.SPINE_STATE:
            s = codec.decode(ch, data)
            if s.seq % 2:
                s.load_cell = np.array([np.nan, np.nan])
            ev[i] = (ch, codec.encode_state(s))
    p2 = tmp_path / "every2.lcm"
    _write(p2, ev)
    tr = load_lcm_log(p2)
    np.testing.assert_allclose(tr.f_ext[:-1, 0], 2.0 * np.arange(29))
    assert tr.f_ext[-1, 0] == 2.0 * 28  # the last reading held
    assert "15 unread samples filled in" in tr.meta["columns"]["f_ext_x"] and tr.meta["lacks"] == []
