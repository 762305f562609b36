"""Trials: a joint log (CSV) plus a JSON sidecar with the same stem; validation names file, row, column.

CSV columns: `t` (s); `q_<joint>` (rad), optional `dq_<joint>` (rad/s) for every non-fixed joint; the torque
of every actuated joint: `tau_cmd_<joint>` (N*m) with the sidecar's `torque_kind: commanded` (default),
`tau_meas_<joint>` with `torque_kind: measured` (then `tau_cmd_` is optional); an external wrench `f_ext_x,
f_ext_z, m_ext_y` (N, N, N*m, base frame, applied at the sidecar's `ee_frame`) is optional.
With a sidecar `transmission`, the actuated joints' columns are motor-side, named by motor
(`q_<motor>` ...; torques in A when torque constants are given) and mapped to the joints on load.
Without dq columns, dq is the Savitzky-Golay derivative of q (zero-phase; window in `meta["dq_source"]`).
Sidecar keys: see `sparc_quad.gap.sidecar`.

The CSV is parsed in one call (`np.loadtxt`); only when that fails is it scanned row by row to say where.
"""

from __future__ import annotations

import csv
import io
import json
from pathlib import Path

import numpy as np

from sparc_quad.gap import lcm_log
from sparc_quad.gap.errors import TrialError
from sparc_quad.gap.lcm_scan import open_checked
from sparc_quad.gap.robot import Robot
from sparc_quad.gap.sidecar import DQ_WINDOW_S, load_sidecar, read_text, sidecar_path
from sparc_quad.gap.trialdata import Trial, robot_for

__all__ = [
    "Trial",
    "TrialError",
    "is_lcm_log",
    "load_lcm_log",
    "load_lcm_segments",
    "load_sidecar",
    "load_trial",
    "robot_for",
    "save_trial",
    "sidecar_path",
]

WRENCH_COLUMNS = ("f_ext_x", "f_ext_z", "m_ext_y")
MIN_ROWS = 16
MAX_PERIOD_DEVIATION = 0.5  # a step between rows off 1/rate_hz by more than this fraction is a gap
MAX_ABS = {"t": 1e10, "q": 1e5, "dq": 1e6, "tau": 1e6, "f": 1e7}  # beyond these a value is garbage, not data


def _locate_parse_error(path: Path, header: list[str], body: str) -> None:
    """Row-by-row scan of a CSV that np.loadtxt refused: raises TrialError at the first bad field."""
    r = 0
    for row in csv.reader(io.StringIO(body)):
        if not row or all(not f.strip() for f in row):
            continue
        r += 1
        if len(row) != len(header):
            raise TrialError(path, f"{len(row)} fields, header has {len(header)}", row=r)
        for c, text in enumerate(row):
            try:
                float(text)
            except ValueError:
                raise TrialError(path, f"not a number: {text!r}", row=r, column=header[c]) from None


def read_csv(path: Path) -> tuple[list[str], np.ndarray]:
    """(header, data) of a numeric CSV with one header line; every value finite."""
    text = read_text(path, "CSV file").replace("\r\n", "\n")
    first, _, body = text.partition("\n")
    if not first.strip():
        raise TrialError(path, "empty file (no header line)")
    header = [h.strip() for h in next(csv.reader([first]))]
    for i, h in enumerate(header):
        if not h:
            raise TrialError(path, f"header field {i + 1} is empty", row=0)
        if header.index(h) != i:
            raise TrialError(path, f"duplicate column {h!r} (fields {header.index(h) + 1} and {i + 1})",
                             row=0, column=h)
    try:
        data = np.loadtxt(io.StringIO(body), delimiter=",", ndmin=2, dtype=float, comments=None)
    except ValueError:
        _locate_parse_error(path, header, body)
        raise TrialError(path, "cannot parse as numbers") from None
    if data.size == 0:
        raise TrialError(path, "no data rows")
    if data.shape[1] != len(header):
        _locate_parse_error(path, header, body)
        raise TrialError(path, f"{data.shape[1]} fields per row, header has {len(header)}")
    bad = np.argwhere(~np.isfinite(data))
    if bad.size:
        r, c = int(bad[0, 0]), int(bad[0, 1])
        raise TrialError(path, f"non-finite value {data[r, c]}", row=r + 1, column=header[c])
    return header, data


def _kind(col: str) -> str:
    if col == "t":
        return "t"
    if col.startswith("f_ext") or col.startswith("m_ext"):
        return "f"
    return col.split("_", 1)[0] if not col.startswith("tau_") else "tau"


def is_lcm_log(path: str | Path) -> bool:
    """An lcm-logger file by its name: `.lcm`, `.lcmlog`, or lcm-logger's default `lcmlog-...`."""
    path = Path(path)
    return path.suffix in (".lcm", ".lcmlog") or path.name.startswith("lcmlog")


def load_trial(path: str | Path, robot: Robot | None = None) -> Trial:
    """Read and validate one trial. Raises TrialError naming file, row and column."""
    path = Path(path)
    if is_lcm_log(path):
        return load_lcm_log(path)
    if not path.exists():
        raise TrialError(path, "file not found")
    if path.is_dir():
        raise TrialError(path, "is a directory, not a trial CSV")
    meta = load_sidecar(path)
    robot = robot or robot_for(path, meta)
    header, data = read_csv(path)
    cols = {name: i for i, name in enumerate(header)}
    for c, name in enumerate(header):
        lim = MAX_ABS.get(_kind(name), MAX_ABS["tau"])
        big = np.nonzero(np.abs(data[:, c]) > lim)[0]
        if big.size:
            raise TrialError(path, f"value {data[big[0], c]:.6g} beyond {lim:g} (not a physical "
                                   "measurement)", row=int(big[0]) + 1, column=name)
    kind = meta["torque_kind"]
    trans = meta.get("transmission")
    act_names = list(trans["motors"]) if trans else list(robot.actuated)
    passive = [j for j in robot.joints if j not in robot.actuated]
    col_of = dict(zip(robot.actuated, act_names, strict=True)) | {j: j for j in passive}
    known = {"t", *WRENCH_COLUMNS}
    for j in robot.joints:
        known |= {f"q_{col_of[j]}", f"dq_{col_of[j]}"}
    for m in act_names:
        known |= {f"tau_cmd_{m}", f"tau_meas_{m}"}
    for name in header:
        if name not in known:
            prefix = name.split("_", 1)[0]
            if prefix in ("q", "dq") or name.startswith("tau_"):
                what = "a motor of the sidecar's transmission" if trans else "a non-fixed joint of the URDF"
                raise TrialError(path, f"column names something that is not {what}", row=0, column=name)
    tau_key = "tau_cmd" if kind == "commanded" else "tau_meas"
    need = ["t", *(f"q_{col_of[j]}" for j in robot.joints), *(f"{tau_key}_{m}" for m in act_names)]
    for name in need:
        if name not in cols:
            raise TrialError(path, f"required column missing (torque_kind {kind})", column=name)
    has_dq = [f"dq_{col_of[j]}" in cols for j in robot.joints]
    if any(has_dq) and not all(has_dq):
        missing = next(f"dq_{col_of[j]}" for j, h in zip(robot.joints, has_dq, strict=True) if not h)
        raise TrialError(path, "give dq for every joint or for none (then it is differentiated from q)",
                         column=missing)
    if len(data) < MIN_ROWS:
        raise TrialError(path, f"{len(data)} data rows; at least {MIN_ROWS} are needed")
    t = data[:, cols["t"]]
    bad = np.nonzero(np.diff(t) <= 0)[0]
    if bad.size:
        raise TrialError(path, "time not strictly increasing", row=int(bad[0]) + 2, column="t")
    rate = float(meta["rate_hz"])
    dt_med = float(np.median(np.diff(t)))
    if abs(dt_med * rate - 1.0) > 0.05:
        raise TrialError(path, f"median sample period {dt_med:.6g} s does not match rate_hz {rate}",
                         column="t")
    off = np.nonzero(np.abs(np.diff(t) * rate - 1.0) > MAX_PERIOD_DEVIATION)[0]
    if off.size:  # rows missing (or doubled): the filters and derivatives assume an even sampling
        r = int(off[0])
        steps = (t[r + 1] - t[r]) * rate
        raise TrialError(path, f"time jumps from {t[r]:.6g} to {t[r + 1]:.6g} s ({steps:.3g} sample periods "
                               f"of 1/rate_hz; {off.size} such step(s)): rows missing? cut the trial "
                               "there into two", row=r + 2, column="t")
    if not np.any(data[:, [c for c in range(len(header)) if header[c] != "t"]]):
        raise TrialError(path, "every value except t is zero: nothing was recorded")

    def get(names):
        return data[:, [cols[n] for n in names]]

    q = get([f"q_{col_of[j]}" for j in robot.joints])
    dq = get([f"dq_{col_of[j]}" for j in robot.joints]) if all(has_dq) else None
    tau = get([f"{tau_key}_{m}" for m in act_names])
    other = "tau_meas" if kind == "commanded" else "tau_cmd"
    tau_other = get([f"{other}_{m}" for m in act_names]) if all(f"{other}_{m}" in cols for m in act_names) \
        else None
    meta = dict(meta)
    if trans:
        q, dq, tau, tau_other = to_joint_space(robot, trans, q, dq, tau, tau_other)
        meta["transmission_applied"] = True
    if not np.any(np.ptp(q, axis=0) > 0):
        raise TrialError(path, "no joint moves (every q column is constant): nothing to identify")
    if dq is None:
        dq, meta["dq_source"] = differentiate(q, rate, meta.get("dq_filter") or {})
    f_ext = None
    if any(c in cols for c in WRENCH_COLUMNS):
        missing = [c for c in WRENCH_COLUMNS if c not in cols]
        if missing:
            raise TrialError(path, "wrench needs f_ext_x, f_ext_z, m_ext_y", column=missing[0])
        if robot.ee_frame is None:
            raise TrialError(sidecar_path(path), "a wrench is logged but the sidecar has no ee_frame",
                             column="ee_frame")
        f_ext = get(list(WRENCH_COLUMNS))
    if kind == "commanded":
        return Trial(path, meta, t, q, dq, tau, tau_other, f_ext, robot)
    return Trial(path, meta, t, q, dq, tau, tau, f_ext, robot, tau_command=tau_other)


def to_joint_space(robot: Robot, trans: dict, q, dq, tau, tau_other):
    """Motor-side columns -> joint side: q_j = G (q_m - offset), dq_j = G dq_m, tau_j = G^-T k_t tau_m."""
    G = np.asarray(trans["motor_to_joint"], float)
    off = np.asarray(trans.get("zero_offsets_rad") or np.zeros(G.shape[1]), float)
    kt = np.asarray(trans.get("torque_constants_nm_per_a") or np.ones(G.shape[1]), float)
    Ginv = np.linalg.inv(G)
    q = q.copy()
    a = robot.act_idx
    q[:, a] = (q[:, a] - off) @ G.T
    if dq is not None:
        dq = dq.copy()
        dq[:, a] = dq[:, a] @ G.T

    def torque(x):
        return None if x is None else (x * kt) @ Ginv

    return q, dq, torque(tau), torque(tau_other)


def differentiate(q: np.ndarray, rate_hz: float, spec: dict) -> tuple[np.ndarray, dict]:
    """Zero-phase Savitzky-Golay derivative of q; returns (dq, how it was made)."""
    from scipy.signal import savgol_filter

    window_s = float(spec.get("window_s", DQ_WINDOW_S))
    order = int(spec.get("polyorder", 3))
    n = round(window_s * rate_hz) | 1  # odd
    n = max(n, order + 2 if (order + 2) % 2 else order + 3)
    if n > len(q):
        n = len(q) if len(q) % 2 else len(q) - 1
    dq = savgol_filter(q, n, order, deriv=1, delta=1.0 / rate_hz, axis=0, mode="interp")
    return dq, {"method": "savitzky_golay_derivative", "zero_phase": True, "window_samples": n,
                "window_s": n / rate_hz, "polyorder": order}


def save_trial(trial: Trial, path: str | Path, meta: dict) -> Path:
    """Write CSV + sidecar (meta is written as given; columns are joint-side)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    robot = trial.robot
    kind = meta.get("torque_kind", "commanded")
    header = ["t", *(f"q_{j}" for j in robot.joints), *(f"dq_{j}" for j in robot.joints)]
    blocks = [trial.t[:, None], trial.q, trial.dq]
    if kind == "commanded":
        header += [f"tau_cmd_{j}" for j in robot.actuated]
        blocks.append(trial.tau_cmd)
        if trial.tau_meas is not None:
            header += [f"tau_meas_{j}" for j in robot.actuated]
            blocks.append(trial.tau_meas)
    else:
        header += [f"tau_meas_{j}" for j in robot.actuated]
        blocks.append(trial.tau_cmd)
        if trial.tau_command is not None:
            header += [f"tau_cmd_{j}" for j in robot.actuated]
            blocks.append(trial.tau_command)
    if trial.f_ext is not None:
        header += list(WRENCH_COLUMNS)
        blocks.append(trial.f_ext)
    arr = np.hstack(blocks)
    np.savetxt(path, arr, delimiter=",", header=",".join(header), comments="", fmt="%.9g")
    sidecar_path(path).write_text(json.dumps(meta, indent=2) + "\n")
    return path


def load_lcm_segments(path: str | Path, min_segment_s: float = lcm_log.MIN_SEGMENT_S) -> list[Trial]:
    """A spine-node session's lcm-logger file as trials: one per segment between gaps of lost spine
    states too long to fill in (`sparc_quad.gap.lcm_log`); refused only when no segment is
    `min_segment_s` long."""
    return lcm_log.load_segments(path, min_segment_s)


def load_lcm_log(path: str | Path, decoder=None) -> Trial:
    """Read an `lcm-logger` file written while the spine node ran.

    By default the node's messages are decoded with its validating codec (`sparc_quad.gap.lcm_log`: one
    sample per spine state; a bad event is named by its number). A custom `decoder(event) -> dict | None`
    returning {"t", "q", "dq", "tau_cmd"} per event reads other logs; it needs a sidecar JSON next to the log.
    Event headers are checked before lcm's reader sees the file (`lcm_scan`).
    """
    path = Path(path)
    if decoder is None:
        return lcm_log.load(path)
    meta = load_sidecar(path)
    robot = robot_for(path, meta)
    rows: list[dict] = []
    log, n_events, _unread = open_checked(path)
    try:
        for i in range(1, n_events + 1):
            event = log.read_next_event()
            try:
                rec = decoder(event)
            except Exception as exc:
                raise TrialError(path, f"event on channel {event.channel!r} does not decode: {exc}",
                                 row=i) from exc
            if rec is not None:
                rows.append(rec)
    finally:
        log.close()
    if not rows:
        raise TrialError(path, "no decodable events")
    t = np.array([r["t"] for r in rows], float)
    q = np.array([r["q"] for r in rows], float)
    dq = np.array([r["dq"] for r in rows], float)
    tau = np.array([r["tau_cmd"] for r in rows], float)
    for name, arr in (("t", t[:, None]), ("q", q), ("dq", dq), ("tau_cmd", tau)):
        bad = np.argwhere(~np.isfinite(arr))
        if bad.size:
            raise TrialError(path, "non-finite value", row=int(bad[0, 0]) + 1, column=name)
    bad = np.nonzero(np.diff(t) <= 0)[0]
    if bad.size:
        raise TrialError(path, "time not strictly increasing", row=int(bad[0]) + 2, column="t")
    if q.shape[1] != robot.nv or tau.shape[1] != len(robot.actuated):
        raise TrialError(path, f"decoded q has {q.shape[1]} joints, the URDF {robot.nv}", column="q")
    return Trial(path, meta, t, q, dq, tau, None, None, robot)
