"""An `lcm-logger` file of a spine-node session as a gap trial.

Every event on a sparc-quad channel (`spine_module.messages.channels`) goes through the node's codec
(`spine_module.messages.decode`): a malformed, truncated or wrong-fingerprint event stops the load with an
error naming the file, the event number (1-based, in log order) and the channel. Events on other channels
(LCM's own `LCM_SELF_TEST`, anything else on the bus) are skipped.

One trial sample per `SPARC_SPINE_STATE` event (the node publishes one per control tick):
- `t`: the state's `utime` (node clock at the start of the tick), s;
- `q_<joint>`, `dq_<joint>`: the state's `q`/`dq` (q1..q4; q1 is the torso state the node used). q1 is
  used only if the sidecar leaves it non-fixed; the bench spine's sidecar fixes it (q1 = 0);
- `tau_cmd_<joint>`: the state's `tau_cmd` (after the node's clamps: what the motors were sent);
- `tau_meas_<joint>`: the state's `tau_est` (the motors' torque estimate) when finite throughout;
- `f_ext_x`: `load_cell[0]` when the sidecar names an `ee_frame` and the reading is finite (NaN runs of at
  most MAX_FILL_TICKS, a cell read every few ticks, are filled in; the bench robot's load cell measures F_x
  along the base x at the front body's tip; `f_ext_z`, `m_ext_y` are 0). Sidecar `"lcm_load_cell": null`
  turns this off.

Spine states travel over UDP: up to MAX_FILL_TICKS states lost in a row (seq jumps) are filled in linearly
in the tick number and listed in `meta["source"]["filled_t"]`; at a longer gap the log is split into
segments, each a trial of its own (`load_segments`; the gaps in `meta["source"]["gaps"]`). A segment
of a split log shorter than MIN_SEGMENT_S is dropped (listed); only a split log with no segment that long
is refused. A seq or time that does not increase is an error naming the event.

What each column was read from is in `meta["columns"]`; what the log lacks for identification (no load
cell, no motor torque estimate) in `meta["lacks"]` and a warning.

The sidecar (same stem, `.json`) is optional: without one the log is taken to be the SPARC bench spine
(`robots/sparc_spine`, q1 fixed at 0, actuated q2..q4, ee frame `end_effector`, `rate_hz` from the
node's rate, 1 kHz, or the median state period when that is far from it), with the CyberGear's and the bench
load cell's `resolution` (the least noise floor) and eq. (4)'s tanh smoothing for the friction effects.
"""

from __future__ import annotations

import itertools
import logging
import os
from pathlib import Path

import numpy as np

from sparc_quad.gap.errors import TrialError
from sparc_quad.gap.lcm_scan import open_checked
from sparc_quad.gap.sidecar import load_sidecar, sidecar_path
from sparc_quad.gap.trialdata import Trial, robot_for
from sparc_quad.robots import spine_urdf_path
from spine_module import params as P

log_ = logging.getLogger(__name__)
NODE_JOINTS = P.ALL_JOINTS  # order of spine_state_t.q / dq: q1..q4
NODE_ACTUATED = P.ACTUATED_JOINTS  # order of tau_cmd / tau_est: q2..q4
SPINE_URDF = spine_urdf_path()


def spine_resolution() -> dict:
    """What the spine's sensors resolve: one LSB of a CyberGear feedback frame (q, dq, torque: 16 bits over
    the frame's ranges) and the load cell's noise (20 kg cell + HX711, params.SENSORS)."""
    s = P.SENSORS
    return {"q_rad": s.position_lsb_rad, "dq_rad_s": s.velocity_lsb_rad_s, "tau_nm": s.torque_lsb_nm,
            "f_ext_n": s.load_cell_noise_n}


def default_meta(path: Path, rate_hz: float) -> dict:
    """The sidecar of a log without one: the SPARC bench spine, its sensors' resolution and its friction
    law's tanh smoothing (eq. 4: 1 / beta)."""
    return {"urdf": os.path.relpath(SPINE_URDF, path.parent), "actuated_joints": list(NODE_ACTUATED),
            "fixed_joints": {P.BASE_JOINT: 0.0}, "gravity": [0.0, 0.0, -9.81], "ee_frame": "end_effector",
            "rate_hz": rate_hz, "description": f"spine-node lcm-logger session {path.name} (bench spine)",
            "resolution": spine_resolution(),
            "friction_smoothing_rad_s": 1.0 / P.NOMINAL_FRICTION.beta_s_rad}


MAX_FILL_TICKS = 5  # spine states lost in a row (UDP) filled in by interpolation; at more the log is split
MIN_SEGMENT_S = 1.0  # a piece between gaps shorter than this is dropped (the filters eat 0.15 s at each end)


def read_states(path: Path):
    """(event numbers, decoded SpineStates, unread tail bytes) of the log's spine-state events; every sparc
    event is validated. Event headers are checked first (`lcm_scan`): unreadable framing before the last
    TAIL_OK_BYTES is an error, and lcm's reader is handed only the whole events."""
    from spine_module.messages import channels, decode

    log, n_events, unread = open_checked(path)
    events, states = [], []
    try:
        for i in range(1, n_events + 1):
            try:
                ev = log.read_next_event()
            except (OSError, ValueError) as exc:  # cannot happen after the scan, but never a traceback
                raise TrialError(path, f"event {i}: cannot read the LCM log past event {i - 1}: {exc}") \
                    from exc
            if ev is None:
                raise TrialError(path, f"event {i}: lcm's reader stopped early")
            if ev.channel not in channels.ALL:
                continue
            try:
                msg = decode(ev.channel, ev.data)
            except Exception as exc:  # MessageError, FingerprintError, or a bad enum value
                raise TrialError(path, f"event {i} (channel {ev.channel!r}, log time {ev.timestamp} us) "
                                       f"rejected: {exc}") from exc
            if ev.channel == channels.SPINE_STATE:
                events.append(i)
                states.append(msg)
    finally:
        log.close()
    if unread > 0:
        log_.warning("%s: last %d bytes (after event %d) are not a whole event (interrupted write?): "
                     "ignored", path, unread, n_events)
    return events, states, unread


def _fill(grid: np.ndarray, seq: np.ndarray, arr: np.ndarray) -> np.ndarray:
    """`arr` (rows at `seq`) on every tick of `grid`, linear in the tick number."""
    flat = arr.reshape(len(arr), -1)
    out = np.column_stack([np.interp(grid, seq, c) for c in flat.T])
    return out.reshape(len(grid), *arr.shape[1:])


def runs(seq: np.ndarray, max_fill: int = MAX_FILL_TICKS) -> list[tuple[int, int]]:
    """[start, end) index ranges of `seq` with no more than `max_fill` ticks lost in a row inside."""
    cuts = np.nonzero(np.diff(seq) > max_fill + 1)[0] + 1
    edges = [0, *cuts.tolist(), len(seq)]
    return list(itertools.pairwise(edges))


def _fill_short_nans(x: np.ndarray, max_fill: int = MAX_FILL_TICKS) -> tuple[np.ndarray, int] | None:
    """`x` with NaN runs of at most `max_fill` samples filled linearly (held at either end): a load cell
    read every few ticks; None when a longer run remains."""
    bad = ~np.isfinite(x)
    if not bad.any():
        return x, 0
    d = np.diff(np.concatenate(([0], bad.astype(np.int8), [0])))
    if bad.all() or np.max(np.nonzero(d == -1)[0] - np.nonzero(d == 1)[0]) > max_fill:
        return None
    k = np.arange(len(x))
    return np.interp(k, k[~bad], x[~bad]), int(bad.sum())


def load_segments(path: str | Path, min_segment_s: float = MIN_SEGMENT_S) -> list[Trial]:
    """The log's segments between unfillable gaps, each a Trial (see the module docstring). Refused
    (TrialError) only when no segment is `min_segment_s` long."""
    path = Path(path)
    events, states, unread = read_states(path)
    if not states:
        raise TrialError(path, "no SPARC_SPINE_STATE events (was the spine node running and on this bus?)")
    t = np.array([s.stamp_s for s in states], float)
    q_all = np.array([s.q for s in states], float)
    dq_all = np.array([s.dq for s in states], float)
    tau_all = np.array([s.tau_cmd for s in states], float)
    est_all = np.array([s.tau_est for s in states], float)
    cell = np.array([s.load_cell[0] for s in states], float)

    def check(name: str, arr: np.ndarray, labels) -> None:
        bad = np.argwhere(~np.isfinite(arr.reshape(len(arr), -1)))
        if bad.size:
            r, c = int(bad[0, 0]), int(bad[0, 1])
            raise TrialError(path, f"event {events[r]} (SPARC_SPINE_STATE seq {states[r].seq}): "
                                   f"{name}[{c}] ({labels[c]}) is {arr.reshape(len(arr), -1)[r, c]}",
                             column=name)

    check("utime", t, ["t"])
    bad = np.nonzero(np.diff(t) <= 0)[0]
    if bad.size:
        r = int(bad[0]) + 1
        raise TrialError(path, f"event {events[r]}: spine-state time {t[r]:.6f} s does not increase "
                               f"(previous state, event {events[r - 1]}: {t[r - 1]:.6f} s)",
                         column="t")
    check("q", q_all, NODE_JOINTS)
    check("dq", dq_all, NODE_JOINTS)
    check("tau_cmd", tau_all, NODE_ACTUATED)
    seq = np.array([s.seq for s in states], np.int64)
    step = np.diff(seq)
    if np.any(step <= 0):
        r = int(np.nonzero(step <= 0)[0][0]) + 1
        raise TrialError(path, f"event {events[r]}: spine-state seq {seq[r]} after {seq[r - 1]} (event "
                               f"{events[r - 1]}) does not increase", column="seq")

    rate = 1.0 / float(np.median(np.diff(t))) if len(t) > 1 else P.CONTROL_RATE_HZ
    if sidecar_path(path).exists():
        meta = load_sidecar(path)
    else:
        nominal = abs(rate / P.CONTROL_RATE_HZ - 1.0) <= 0.05
        meta = default_meta(path, P.CONTROL_RATE_HZ if nominal else round(rate, 3))
    robot = robot_for(path, meta)
    side = sidecar_path(path)
    for j in robot.joints:
        if j not in NODE_JOINTS:
            raise TrialError(side, f"joint {j!r} of the URDF is not one the spine node logs "
                                   f"({', '.join(NODE_JOINTS)}); fix it in fixed_joints",
                             column="fixed_joints")
    for j in robot.actuated:
        if j not in NODE_ACTUATED:
            raise TrialError(side, f"actuated joint {j!r} has no motor in the spine node "
                                   f"({', '.join(NODE_ACTUATED)})", column="actuated_joints")
    if abs(rate / float(meta["rate_hz"]) - 1.0) > 0.05:
        raise TrialError(path, f"median spine-state period {1.0 / rate:.6g} s does not match rate_hz "
                               f"{meta['rate_hz']}", column="t")
    qi = [NODE_JOINTS.index(j) for j in robot.joints]
    ai = [NODE_ACTUATED.index(j) for j in robot.actuated]
    min_ticks = max(2, round(min_segment_s * float(meta["rate_hz"])))

    pieces = runs(seq)
    gaps = [{"after_seq": int(seq[a - 1]), "before_seq": int(seq[a]), "lost": int(seq[a] - seq[a - 1] - 1),
             "t0_s": float(t[a - 1]), "t1_s": float(t[a]), "event": int(events[a])}
            for a, _ in pieces[1:]]
    for g in gaps:
        log_.warning("%s: %d spine states missing between seq %d and %d (t %.4f-%.4f s; more than %d in a "
                     "row cannot be filled in): the log is split there", path, g["lost"], g["after_seq"],
                     g["before_seq"], g["t0_s"], g["t1_s"], MAX_FILL_TICKS)
    # a log without gaps loads whole, however short; pieces of a split log must each be long enough
    kept = pieces if not gaps else [(a, b) for a, b in pieces if seq[b - 1] - seq[a] + 1 >= min_ticks]
    dropped = [{"first_seq": int(seq[a]), "last_seq": int(seq[b - 1]), "t0_s": float(t[a]),
                "t1_s": float(t[b - 1])} for a, b in pieces if (a, b) not in kept]
    if not kept:
        longest = max((t[b - 1] - t[a]) for a, b in pieces)
        raise TrialError(path, f"too little left to identify: {len(gaps)} gap(s) of more than "
                               f"{MAX_FILL_TICKS} lost spine states split the log into pieces of at most "
                               f"{longest:.3f} s, fewer than {min_segment_s:g} s each", column="seq")
    lacks, columns = _sources(robot, meta, est_all[:, ai], cell)
    for what in lacks:
        log_.warning("%s: %s", path, what)
    trials = []
    for n_seg, (a, b) in enumerate(kept):
        grid = np.arange(seq[a], seq[b - 1] + 1)
        sl = slice(a, b)
        lost = ~np.isin(grid, seq[sl])
        cols = [_fill(grid, seq[sl], x[sl]) for x in (t, q_all, dq_all, tau_all, est_all)]
        tt, qq, dqq, tau, est = cols
        c_raw = cell[sl]
        c = _fill(grid, seq[sl][np.isfinite(c_raw)], c_raw[np.isfinite(c_raw)]) \
            if np.isfinite(c_raw).sum() >= 2 else np.full(len(grid), np.nan)
        filled = tt[lost].tolist()
        if filled:
            log_.warning("%s: %d spine state(s) missing from the log (lost datagrams?), filled in linearly "
                         "at t = %s s", path, len(filled), ", ".join(f"{x:.4f}" for x in filled[:10]))
        tau_meas = est[:, ai] if "tau_meas" in columns else None
        f_ext = None
        if "f_ext_x" in columns:
            f_ext = np.zeros((len(grid), 3))
            f_ext[:, 0] = c
        name = path if len(kept) == 1 else path.with_name(f"{path.stem}_seg{n_seg:02d}{path.suffix}")
        source = {"lcm_log": path.name, "events": int(events[-1]), "spine_states": int(b - a),
                  "first_seq": int(seq[a]), "last_seq": int(seq[b - 1]), "unread_tail_bytes": int(unread),
                  "filled_t": filled, "segment": n_seg, "segments": len(kept), "gaps": gaps,
                  "dropped_segments": dropped, "spine_states_in_log": len(states)}
        seg_meta = {**meta, "columns": columns, "lacks": lacks, "source": source}
        trials.append(Trial(name, seg_meta, tt, qq[:, qi], dqq[:, qi], tau[:, ai], tau_meas, f_ext, robot))
    return trials


def _sources(robot, meta: dict, est: np.ndarray, cell: np.ndarray) -> tuple[list[str], dict]:
    """(what the log lacks for identification, column -> where it was read from)."""
    lacks: list[str] = []
    columns = {"t": "SPARC_SPINE_STATE.utime (node clock at the tick)"}
    for j in robot.joints:
        i = NODE_JOINTS.index(j)
        src = ("the torso state the node used (SPARC_SPINE_STATE.q[0], dq[0] = SPARC_TORSO_STATE.q1, dq1)"
               if j == P.BASE_JOINT else "the motor feedback the node used (CyberGear frame)")
        columns[f"q_{j}"] = f"SPARC_SPINE_STATE.q[{i}]: {src}"
        columns[f"dq_{j}"] = f"SPARC_SPINE_STATE.dq[{i}]"
    for j in robot.actuated:
        i = NODE_ACTUATED.index(j)
        columns[f"tau_cmd_{j}"] = f"SPARC_SPINE_STATE.tau_cmd[{i}]: the torque sent (after clamps)"
    if np.all(np.isfinite(est)):
        for j in robot.actuated:
            columns[f"tau_meas_{j}"] = (f"SPARC_SPINE_STATE.tau_est[{NODE_ACTUATED.index(j)}]: the torque "
                                        "the motor reports (feedback frame), beside the command")
        columns["tau_meas"] = "tau_est of every actuated joint"
    else:
        lacks.append("tau_meas: the motors' reported torque (SPARC_SPINE_STATE.tau_est) is not finite "
                     "throughout; only the commanded torque is in the trial")
    use_cell = meta.get("lcm_load_cell", "f_ext_x") == "f_ext_x"
    if robot.ee_frame is None or not use_cell:
        lacks.append("f_ext: no external force (the sidecar names no ee_frame or sets lcm_load_cell to "
                     "null): a push on the spine during the log is not modelled")
    else:
        filled = _fill_short_nans(cell)
        if filled is None:
            n_nan = int((~np.isfinite(cell)).sum())
            lacks.append(f"f_ext: SPARC_SPINE_STATE.load_cell[0] is NaN in {n_nan} of {len(cell)} states "
                         "(no load cell on the rig, or read too rarely): the trial has no external force; "
                         "a push during the log will be named as some other effect")
        else:
            columns["f_ext_x"] = (f"SPARC_SPINE_STATE.load_cell[0] (N, along the base x at {robot.ee_frame})"
                                  + (f"; {filled[1]} unread samples filled in linearly" if filled[1] else ""))
            columns["f_ext"] = "load cell as f_ext_x; f_ext_z and m_ext_y are 0 (not measured)"
    return lacks, columns


def load(path: str | Path, min_segment_s: float = MIN_SEGMENT_S) -> Trial:
    """The log as one Trial; a log split by unfillable gaps into several segments is an error here that
    says so (`load_segments` and `gap run` take every segment)."""
    trials = load_segments(path, min_segment_s)
    if len(trials) > 1:
        gaps = trials[0].meta["source"]["gaps"]
        raise TrialError(path, f"{len(gaps)} gap(s) of more than {MAX_FILL_TICKS} lost spine states split "
                               f"the log into {len(trials)} segments (first at seq {gaps[0]['after_seq']}-"
                               f"{gaps[0]['before_seq']}); load it with load_lcm_segments, or `gap run` it: "
                               "each segment is a trial", column="seq")
    return trials[0]
