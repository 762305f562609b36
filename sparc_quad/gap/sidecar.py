"""The trial sidecar (JSON beside a CSV or lcm log): read, validate every field, name the file and key.

Keys (SI units):
- `urdf` (str, relative to the sidecar), `actuated_joints` (list of str), `fixed_joints` (name -> rad),
  `gravity` (3 numbers, m/s^2), `rate_hz` (> 0): required;
- `ee_frame`, `description`, `plant` (a plant-effects file with the known, nominal effects): optional;
- `period_s` (> 0): the excitation repeats with this period (used for the noise floor);
- `torque_kind`: `commanded` (default: the torque columns are what the controller sent; actuator effects
  on the command -- deadband, saturation, delay, gain -- are candidates) or `measured` (the torque columns
  are measured, e.g. motor current x torque constant: those actuator effects are not candidates);
- `transmission` (optional): the log is motor-side, as recorded. Object with
    `motors`: names m_1..m_n, the column suffixes (`q_<m>`, `dq_<m>`, `tau_cmd_<m>` / `tau_meas_<m>`);
    `motor_to_joint`: matrix G (n_actuated x n_motors, rows in `actuated_joints` order):
        dq_joint = G dq_motor (gear ratios as 1/N, signs, coupling, e.g. a wrist row [.., -1/N5, 1/N6]);
        joint torque = G^-T motor torque (power balance), so G must be square and invertible;
    `torque_constants_nm_per_a` (optional, n_motors): the torque columns hold currents (A); motor
        torque = k_t * current;
    `zero_offsets_rad` (optional, n_motors): motor encoder reading at joint zero:
        q_joint = G (q_motor - offset);
- `resolution` (optional): the sensors' resolution, which sets the least noise floor the gap is measured
  against (`gap/resolution_floor.py`): `{"q_rad", "dq_rad_s", "tau_nm", "f_ext_n"}`, each >= 0 (a missing
  key: only the numbers' precision);
- `friction_smoothing_rad_s` (optional, > 0): sign(dq) is tanh(dq / this) in the friction effects when no
  nominal plant file says otherwise (the spine's eq. (4): 1 / beta);
- `dq_filter` (optional): how dq is differentiated when the CSV has no dq columns:
  `{"window_s": w, "polyorder": p}` for a Savitzky-Golay derivative (zero-phase; default window
  DQ_WINDOW_S, polyorder 3).
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from sparc_quad.gap.errors import TrialError

REQUIRED_KEYS = ("urdf", "actuated_joints", "fixed_joints", "gravity", "rate_hz")
TORQUE_KINDS = ("commanded", "measured")
DQ_WINDOW_S = 0.01
RESOLUTION_KEYS = ("q_rad", "dq_rad_s", "tau_nm", "f_ext_n")
MAX_RATE_HZ = 1e6
MAX_FIXED_RAD = 1e3  # a fixed joint's position (rad, or m for a prismatic one)
MAX_GRAVITY_M_S2 = 1e3  # 100 g: beyond it the number is not a gravity
MAX_DQ_WINDOW_S = 10.0
MAX_PERIOD_S = 1e4


def sidecar_path(csv_path: Path) -> Path:
    return Path(csv_path).with_suffix(".json")


def read_text(path: Path, what: str) -> str:
    """The file's text: UTF-8 (a leading byte-order mark is accepted and dropped)."""
    if path.is_dir():
        raise TrialError(path, f"is a directory, not a {what}")
    if path.exists() and not path.is_file():  # a FIFO would block the read forever
        raise TrialError(path, f"not a regular file (a FIFO, device or socket?), not a {what}")
    try:
        raw = path.read_bytes()
    except OSError as exc:
        raise TrialError(path, f"cannot read: {exc.strerror or exc}") from exc
    try:
        return raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise TrialError(path, f"not UTF-8 text (byte {exc.start}: {raw[exc.start:exc.start + 1]!r}); "
                               "save it as UTF-8") from None


def _number(side: Path, key: str, v, *, positive: bool = False, allow_zero: bool = True) -> float:
    if isinstance(v, bool) or not isinstance(v, int | float):
        raise TrialError(side, f"{key} must be a number, got {json.dumps(v)}", column=key)
    x = float(v)
    if not math.isfinite(x):
        raise TrialError(side, f"{key} must be finite, got {v}", column=key)
    if positive and (x < 0 or (x == 0 and not allow_zero)):
        raise TrialError(side, f"{key} must be > 0, got {v}", column=key)
    return x


def _str_list(side: Path, key: str, v, n: int | None = None) -> list[str]:
    if not isinstance(v, list) or not v or not all(isinstance(s, str) and s for s in v):
        raise TrialError(side, f"{key} must be a non-empty list of names, got {json.dumps(v)}", column=key)
    if len(set(v)) != len(v):
        dup = next(s for s in v if v.count(s) > 1)
        raise TrialError(side, f"{key} names {dup!r} twice", column=key)
    if n is not None and len(v) != n:
        raise TrialError(side, f"{key} has {len(v)} entries, expected {n}", column=key)
    return list(v)


def _vector(side: Path, key: str, v, n: int) -> np.ndarray:
    if not isinstance(v, list) or len(v) != n:
        raise TrialError(side, f"{key} must be a list of {n} numbers, got {json.dumps(v)}", column=key)
    return np.array([_number(side, f"{key}[{i}]", x) for i, x in enumerate(v)])


def validate(side: Path, meta) -> dict:
    """Check every key; returns meta with defaults filled in (`torque_kind`)."""
    if not isinstance(meta, dict):
        raise TrialError(side, f"sidecar must be a JSON object, got {type(meta).__name__} "
                               f"{json.dumps(meta)[:60]}")
    for key in REQUIRED_KEYS:
        if key not in meta:
            raise TrialError(side, f"missing key {key!r}", column=key)
    if not isinstance(meta["urdf"], str) or not meta["urdf"]:
        raise TrialError(side, f"urdf must be a path string, got {json.dumps(meta['urdf'])}", column="urdf")
    _str_list(side, "actuated_joints", meta["actuated_joints"])
    fixed = meta["fixed_joints"]
    if not isinstance(fixed, dict):
        raise TrialError(side, f"fixed_joints must be an object name -> rad, got {json.dumps(fixed)}",
                         column="fixed_joints")
    for k, v in fixed.items():
        x = _number(side, f"fixed_joints.{k}", v)
        if abs(x) > MAX_FIXED_RAD:
            raise TrialError(side, f"fixed_joints.{k} = {x:g} beyond {MAX_FIXED_RAD:g} (rad or m): not a "
                                   "joint position", column=f"fixed_joints.{k}")
    g = _vector(side, "gravity", meta["gravity"], 3)
    if np.max(np.abs(g)) > MAX_GRAVITY_M_S2:
        raise TrialError(side, f"gravity component {np.max(np.abs(g)):g} m/s^2 beyond {MAX_GRAVITY_M_S2:g} "
                               "m/s^2", column="gravity")
    rate = _number(side, "rate_hz", meta["rate_hz"], positive=True, allow_zero=False)
    if rate > MAX_RATE_HZ:
        raise TrialError(side, f"rate_hz {rate} above {MAX_RATE_HZ:g}", column="rate_hz")
    if meta.get("period_s") is not None:
        period = _number(side, "period_s", meta["period_s"], positive=True, allow_zero=False)
        if period * rate < 2 or period > MAX_PERIOD_S:
            raise TrialError(side, f"period_s {period:g} s: an excitation period spans at least 2 samples "
                                   f"(1/rate_hz = {1 / rate:g} s) and at most {MAX_PERIOD_S:g} s",
                             column="period_s")
    for key in ("ee_frame", "plant", "description"):
        if meta.get(key) is not None and not isinstance(meta[key], str):
            raise TrialError(side, f"{key} must be a string, got {json.dumps(meta[key])}", column=key)
    kind = meta.get("torque_kind", "commanded")
    if kind not in TORQUE_KINDS:
        raise TrialError(side, f"torque_kind must be one of {TORQUE_KINDS}, got {json.dumps(kind)}",
                         column="torque_kind")
    out = {**meta, "torque_kind": kind}
    if meta.get("transmission") is not None:
        out["transmission"] = transmission(side, meta["transmission"], meta["actuated_joints"])
    if meta.get("dq_filter") is not None:
        f = meta["dq_filter"]
        if not isinstance(f, dict) or set(f) - {"window_s", "polyorder"}:
            raise TrialError(side, "dq_filter must be {'window_s': s, 'polyorder': n}, got "
                                   f"{json.dumps(f)}", column="dq_filter")
        if "window_s" in f:
            w = _number(side, "dq_filter.window_s", f["window_s"], positive=True, allow_zero=False)
            if w > MAX_DQ_WINDOW_S:
                raise TrialError(side, f"dq_filter.window_s {w:g} s beyond {MAX_DQ_WINDOW_S:g} s (a "
                                       "derivative window is milliseconds)", column="dq_filter")
        if "polyorder" in f and (not isinstance(f["polyorder"], int) or not 1 <= f["polyorder"] <= 6):
            raise TrialError(side, "dq_filter.polyorder must be an integer in 1..6", column="dq_filter")
    if meta.get("resolution") is not None:
        res = meta["resolution"]
        if not isinstance(res, dict) or set(res) - set(RESOLUTION_KEYS):
            raise TrialError(side, f"resolution must be an object with some of {list(RESOLUTION_KEYS)}, got "
                                   f"{json.dumps(res)[:80]}", column="resolution")
        for k, v in res.items():
            _number(side, f"resolution.{k}", v, positive=True)
    if meta.get("friction_smoothing_rad_s") is not None:
        _number(side, "friction_smoothing_rad_s", meta["friction_smoothing_rad_s"], positive=True,
                allow_zero=False)
    return out


def transmission(side: Path, tr, actuated: list[str]) -> dict:
    """Validated transmission block (see the module docstring); keeps the JSON form, adds nothing."""
    if not isinstance(tr, dict):
        raise TrialError(side, f"transmission must be an object, got {json.dumps(tr)[:60]}",
                         column="transmission")
    unknown = set(tr) - {"motors", "motor_to_joint", "torque_constants_nm_per_a", "zero_offsets_rad"}
    if unknown:
        raise TrialError(side, f"transmission: unknown key(s) {sorted(unknown)}", column="transmission")
    if "motors" not in tr or "motor_to_joint" not in tr:
        raise TrialError(side, "transmission needs 'motors' and 'motor_to_joint'", column="transmission")
    motors = _str_list(side, "transmission.motors", tr["motors"], len(actuated))
    G = tr["motor_to_joint"]
    if not isinstance(G, list) or len(G) != len(actuated):
        raise TrialError(side, f"transmission.motor_to_joint must have {len(actuated)} rows (one per "
                               "actuated joint)", column="transmission")
    rows = [_vector(side, f"transmission.motor_to_joint[{i}]", r, len(motors)) for i, r in enumerate(G)]
    Gm = np.vstack(rows)
    if np.linalg.cond(Gm) > 1e12:
        raise TrialError(side, "transmission.motor_to_joint is singular (a joint no motor moves?)",
                         column="transmission")
    for key in ("torque_constants_nm_per_a", "zero_offsets_rad"):
        if tr.get(key) is not None:
            v = _vector(side, f"transmission.{key}", tr[key], len(motors))
            if key == "torque_constants_nm_per_a" and np.any(v == 0):
                raise TrialError(side, f"transmission.{key} has a zero entry", column="transmission")
    return dict(tr)


def load_sidecar(csv_path: Path) -> dict:
    side = sidecar_path(csv_path)
    if not side.exists():
        raise TrialError(side, "sidecar JSON missing (same stem as the CSV)")
    text = read_text(side, "JSON sidecar")
    try:
        meta = json.loads(text)
    except json.JSONDecodeError as exc:
        raise TrialError(side, f"not valid JSON: {exc}") from exc
    return validate(side, meta)
