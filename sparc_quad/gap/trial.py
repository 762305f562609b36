"""Trials: a joint log (CSV) plus a JSON sidecar with the same stem; validation names file, row, column.

CSV columns: `t` (s); `q_<joint>` (rad), `dq_<joint>` (rad/s) for every non-fixed joint; `tau_cmd_<joint>`
(N*m) for every actuated joint; optional `tau_meas_<joint>` and an external wrench `f_ext_x, f_ext_z,
m_ext_y` (N, N, N*m, base frame, applied at the sidecar's `ee_frame`).
Sidecar keys: `urdf` (path, relative to the sidecar), `actuated_joints`, `fixed_joints` (name -> value),
`gravity`, `ee_frame`, `rate_hz`, `description`; optional `period_s` (the excitation repeats with this
period: used for the noise floor) and `plant` (a plant-effects file holding the known, nominal effects).
"""

from __future__ import annotations

import csv
import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from sparc_quad.gap.robot import Robot, RobotError

WRENCH_COLUMNS = ("f_ext_x", "f_ext_z", "m_ext_y")
REQUIRED_KEYS = ("urdf", "actuated_joints", "fixed_joints", "gravity", "rate_hz")


class TrialError(ValueError):
    """Bad input. `file`, `row` (1-based data row, header excluded) and `column` say where."""

    def __init__(self, file: str | Path, message: str, row: int | None = None, column: str | None = None):
        self.file, self.row, self.column = str(file), row, column
        where = str(file)
        if row is not None:
            where += f", row {row} (line {row + 1})"
        if column is not None:
            where += f", column {column!r}"
        super().__init__(f"{where}: {message}")


@dataclass
class Trial:
    path: Path  # the CSV
    meta: dict
    t: np.ndarray
    q: np.ndarray  # (N, nv) in the robot's joint order
    dq: np.ndarray
    tau_cmd: np.ndarray  # (N, na) in actuated order
    tau_meas: np.ndarray | None = None
    f_ext: np.ndarray | None = None
    robot: Robot | None = field(default=None, repr=False)

    @property
    def name(self) -> str:
        return self.path.stem

    @property
    def rate_hz(self) -> float:
        return float(self.meta["rate_hz"])

    @property
    def dt(self) -> float:
        return 1.0 / self.rate_hz

    def plant_path(self) -> Path | None:
        p = self.meta.get("plant")
        return None if p is None else (self.path.parent / p)

    def slice(self, a: int, b: int, suffix: str) -> Trial:
        def cut(x):
            return None if x is None else x[a:b]

        return Trial(self.path.with_name(f"{self.path.stem}{suffix}.csv"), self.meta, self.t[a:b],
                     self.q[a:b], self.dq[a:b], self.tau_cmd[a:b], cut(self.tau_meas), cut(self.f_ext),
                     self.robot)


def sidecar_path(csv_path: Path) -> Path:
    return csv_path.with_suffix(".json")


def load_sidecar(csv_path: Path) -> dict:
    side = sidecar_path(csv_path)
    if not side.exists():
        raise TrialError(side, "sidecar JSON missing (same stem as the CSV)")
    try:
        meta = json.loads(side.read_text())
    except json.JSONDecodeError as exc:
        raise TrialError(side, f"not valid JSON: {exc}") from exc
    for key in REQUIRED_KEYS:
        if key not in meta:
            raise TrialError(side, f"missing key {key!r}", column=key)
    return meta


def robot_for(csv_path: Path, meta: dict) -> Robot:
    side = sidecar_path(csv_path)
    urdf = Path(meta["urdf"])
    if not urdf.is_absolute():
        urdf = side.parent / urdf
    try:
        return Robot(urdf.resolve(), meta["actuated_joints"], meta.get("fixed_joints", {}), meta["gravity"],
                     meta.get("ee_frame"))
    except RobotError as exc:
        raise TrialError(side, str(exc)) from exc


def load_trial(path: str | Path, robot: Robot | None = None) -> Trial:
    """Read and validate one trial. Raises TrialError naming file, row and column."""
    path = Path(path)
    if path.suffix in (".lcm", ".lcmlog") or path.name.startswith("lcmlog"):
        return load_lcm_log(path)
    if not path.exists():
        raise TrialError(path, "file not found")
    meta = load_sidecar(path)
    robot = robot or robot_for(path, meta)
    with path.open(newline="") as fh:
        reader = csv.reader(fh)
        try:
            header = [h.strip() for h in next(reader)]
        except StopIteration:
            raise TrialError(path, "empty file") from None
        rows = list(reader)
    if not rows:
        raise TrialError(path, "no data rows")
    cols = {name: i for i, name in enumerate(header)}
    known = {"t", *WRENCH_COLUMNS}
    for j in robot.joints:
        known |= {f"q_{j}", f"dq_{j}"}
    for j in robot.actuated:
        known |= {f"tau_cmd_{j}", f"tau_meas_{j}"}
    for name in header:
        if name not in known:
            prefix = name.split("_", 1)[0]
            if prefix in ("q", "dq") or name.startswith("tau_"):
                raise TrialError(path, "column names a joint that is not a non-fixed joint of the URDF",
                                 row=0, column=name)
    need = ["t", *(f"q_{j}" for j in robot.joints), *(f"dq_{j}" for j in robot.joints),
            *(f"tau_cmd_{j}" for j in robot.actuated)]
    for name in need:
        if name not in cols:
            raise TrialError(path, "required column missing", column=name)
    data = np.empty((len(rows), len(header)))
    for r, row in enumerate(rows, start=1):
        if len(row) != len(header):
            raise TrialError(path, f"{len(row)} fields, header has {len(header)}", row=r)
        for c, text in enumerate(row):
            try:
                v = float(text)
            except ValueError:
                raise TrialError(path, f"not a number: {text!r}", row=r, column=header[c]) from None
            if not np.isfinite(v):
                raise TrialError(path, f"non-finite value {text!r}", row=r, column=header[c])
            data[r - 1, c] = v
    t = data[:, cols["t"]]
    bad = np.nonzero(np.diff(t) <= 0)[0]
    if bad.size:
        raise TrialError(path, "time not strictly increasing", row=int(bad[0]) + 2, column="t")
    def get(names):
        return data[:, [cols[n] for n in names]]

    tau_meas = None
    if all(f"tau_meas_{j}" in cols for j in robot.actuated):
        tau_meas = get([f"tau_meas_{j}" for j in robot.actuated])
    f_ext = None
    if any(c in cols for c in WRENCH_COLUMNS):
        missing = [c for c in WRENCH_COLUMNS if c not in cols]
        if missing:
            raise TrialError(path, "wrench needs f_ext_x, f_ext_z, m_ext_y", column=missing[0])
        if robot.ee_frame is None:
            raise TrialError(sidecar_path(path), "a wrench is logged but the sidecar has no ee_frame",
                             column="ee_frame")
        f_ext = get(list(WRENCH_COLUMNS))
    rate = float(meta["rate_hz"])
    dt_med = float(np.median(np.diff(t))) if len(t) > 1 else 1.0 / rate
    if abs(dt_med * rate - 1.0) > 0.05:
        raise TrialError(path, f"median sample period {dt_med:.6g} s does not match rate_hz {rate}",
                         column="t")
    return Trial(path, meta, t, get([f"q_{j}" for j in robot.joints]), get([f"dq_{j}" for j in robot.joints]),
                 get([f"tau_cmd_{j}" for j in robot.actuated]), tau_meas, f_ext, robot)


def save_trial(trial: Trial, path: str | Path, meta: dict) -> Path:
    """Write CSV + sidecar (meta is written as given)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    robot = trial.robot
    header = ["t", *(f"q_{j}" for j in robot.joints), *(f"dq_{j}" for j in robot.joints),
              *(f"tau_cmd_{j}" for j in robot.actuated)]
    blocks = [trial.t[:, None], trial.q, trial.dq, trial.tau_cmd]
    if trial.tau_meas is not None:
        header += [f"tau_meas_{j}" for j in robot.actuated]
        blocks.append(trial.tau_meas)
    if trial.f_ext is not None:
        header += list(WRENCH_COLUMNS)
        blocks.append(trial.f_ext)
    arr = np.hstack(blocks)
    np.savetxt(path, arr, delimiter=",", header=",".join(header), comments="", fmt="%.9g")
    sidecar_path(path).write_text(json.dumps(meta, indent=2) + "\n")
    return path


def load_lcm_log(path: str | Path, decoder=None) -> Trial:
    """Read an `lcm-logger` file written while the spine node ran.

    By default the node's messages are decoded with its validating codec (`sparc_quad.gap.lcm_log`: one
    sample per spine state; a bad event is named by its number). A custom `decoder(event) -> dict | None`
    returning {"t", "q", "dq", "tau_cmd"} per event reads other logs; it needs a sidecar JSON next to the log.
    """
    import lcm

    path = Path(path)
    if decoder is None:
        from sparc_quad.gap.lcm_log import load

        return load(path)
    meta = load_sidecar(path)
    robot = robot_for(path, meta)
    rows: list[dict] = []
    try:
        log = lcm.EventLog(str(path), "r")
    except OSError as exc:
        raise TrialError(path, f"cannot open LCM log: {exc}") from exc
    for i, event in enumerate(log, start=1):
        try:
            rec = decoder(event)
        except Exception as exc:
            raise TrialError(path, f"event on channel {event.channel!r} does not decode: {exc}",
                             row=i) from exc
        if rec is not None:
            rows.append(rec)
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
