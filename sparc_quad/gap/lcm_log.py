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
- `f_ext_x`: `load_cell[0]` when the sidecar names an `ee_frame` and the reading is finite throughout
  (the bench robot's load cell measures F_x along the base x at the front body's tip; `f_ext_z`, `m_ext_y`
  are 0). Sidecar `"lcm_load_cell": null` turns this off.

Spine states travel over UDP: up to MAX_FILL_TICKS states lost in a row (seq jumps) are filled in linearly
in the tick number and listed in `meta["source"]["filled_t"]`; a longer gap, a seq or time that does not
increase, is an error naming the event.

The sidecar (same stem, `.json`) is optional: without one the log is taken to be the SPARC bench spine
(`robots/sparc_spine`, q1 fixed at 0, actuated q2..q4, ee frame `end_effector`, `rate_hz` from the
node's rate, 1 kHz, or the median state period when that is far from it).
"""

from __future__ import annotations

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


def default_meta(path: Path, rate_hz: float) -> dict:
    """The sidecar of a log without one: the SPARC bench spine."""
    return {"urdf": os.path.relpath(SPINE_URDF, path.parent), "actuated_joints": list(NODE_ACTUATED),
            "fixed_joints": {P.BASE_JOINT: 0.0}, "gravity": [0.0, 0.0, -9.81], "ee_frame": "end_effector",
            "rate_hz": rate_hz, "description": f"spine-node lcm-logger session {path.name} (bench spine)"}


MAX_FILL_TICKS = 5  # spine states lost in a row (UDP) that are filled in by interpolation; more is an error


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


def load(path: str | Path):
    """Read an lcm-logger file of a spine-node session as a `Trial` (see the module docstring)."""

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
    if np.any(step > MAX_FILL_TICKS + 1):
        r = int(np.nonzero(step > MAX_FILL_TICKS + 1)[0][0]) + 1
        raise TrialError(path, f"event {events[r]}: {int(step[r - 1]) - 1} spine states missing between seq "
                               f"{seq[r - 1]} (event {events[r - 1]}) and {seq[r]}; at most {MAX_FILL_TICKS} "
                               "lost in a row are filled in (cut the log there, load both parts as trials)",
                         column="seq")
    filled: list[float] = []
    if np.any(step > 1):  # a datagram the logger missed: fill the tick in, linearly in the tick number
        grid = np.arange(seq[0], seq[-1] + 1)
        lost = ~np.isin(grid, seq)

        def fill(arr: np.ndarray) -> np.ndarray:
            flat = arr.reshape(len(arr), -1)
            out = np.column_stack([np.interp(grid, seq, c) for c in flat.T])
            return out.reshape(len(grid), *arr.shape[1:])

        t, q_all, dq_all = fill(t), fill(q_all), fill(dq_all)
        tau_all, est_all, cell = fill(tau_all), fill(est_all), fill(cell)
        filled = t[lost].tolist()
        log_.warning("%s: %d spine state(s) missing from the log (lost datagrams?), filled in linearly at "
                     "t = %s s", path, len(filled), ", ".join(f"{x:.4f}" for x in filled[:10]))

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
    qi = [NODE_JOINTS.index(j) for j in robot.joints]
    ai = [NODE_ACTUATED.index(j) for j in robot.actuated]
    if abs(rate / float(meta["rate_hz"]) - 1.0) > 0.05:
        raise TrialError(path, f"median spine-state period {1.0 / rate:.6g} s does not match rate_hz "
                               f"{meta['rate_hz']}", column="t")
    tau_meas = est_all[:, ai] if np.all(np.isfinite(est_all[:, ai])) else None
    f_ext = None
    if robot.ee_frame is not None and meta.get("lcm_load_cell", "f_ext_x") == "f_ext_x" \
            and np.all(np.isfinite(cell)):
        f_ext = np.zeros((len(t), 3))
        f_ext[:, 0] = cell
    meta = {**meta, "source": {"lcm_log": path.name, "events": int(events[-1]), "spine_states": len(states),
                               "first_seq": int(states[0].seq), "last_seq": int(states[-1].seq),
                               "unread_tail_bytes": int(unread), "filled_t": filled}}
    return Trial(path, meta, t, q_all[:, qi], dq_all[:, qi], tau_all[:, ai], tau_meas, f_ext, robot)
