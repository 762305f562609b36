"""Import the Stäubli TX40 identification log published with FIGAROH into the gap trial format.

Source: github.com/thanhndv212/figaroh-plus (Apache-2.0), `examples/staubli_TX40/data/` — motor encoder
positions (`pos_read_data.csv`, rad on the motor side) and motor torques (`curr_data.csv`, motor side;
FIGAROH's own processing multiplies them by the gear ratio only, i.e. a unit torque constant), 45 000
samples at 5 kHz (sample period 0.2 ms from the published `T40X_config.yaml`), and the robot's URDF
(`tx40_mdh_modified.urdf`, modified-DH frames; its last link is massless). The wrist is coupled: motor 6
turns with q5 + q6. See tests/data/staubli_tx40/README.md.

A trial written here keeps the motor-side signals as recorded (`q_<motor>` rad, `tau_meas_<motor>` N*m;
no dq: the reader differentiates q); the sidecar's `transmission` (see `sparc_quad.gap.sidecar`) maps them
to the URDF's joints as FIGAROH's `identification.py` and `T40X_config.yaml` do:

    q_joint   = G (q_motor - zero_offsets_rad),   G = T^-1,  q_motor = T q_joint at the URDF's zero
    tau_joint = G^-T tau_motor = T^T tau_motor                        (power balance)

with T = diag(32, 32, 45, -48, 45, 32) plus T[5, 4] = 32 (motor 6 turns with q5 + q6).

    python -m sparc_quad.gap.import_tx40 --source DIR --out DIR [--decimate 5] [--window 0.5:3.5 ...]
"""

from __future__ import annotations

import argparse
import os
import sys
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

from sparc_quad.gap.import_util import (
    LogImportError,
    add_decimate_and_window,
    decimate,
    find_source,
    importer_main,
    read_table,
    write_trial_csv,
)

SOURCE_REPO = "https://github.com/thanhndv212/figaroh-plus"
SOURCE_COMMIT = "c3b5172"  # figaroh-plus main when imported; the data files date from dd270af (2023-01-23)
SOURCE_FILES = {"position": "pos_read_data.csv", "torque": "curr_data.csv"}
URDF_NAME = "tx40_mdh_modified.urdf"
RATE_HZ = 5000.0  # T40X_config.yaml: ts = 0.0002 s
JOINTS = [f"joint_{i}" for i in range(1, 7)]
MOTORS = [f"m{i}" for i in range(1, 7)]
GEAR_RATIOS = (32.0, 32.0, 45.0, -48.0, 45.0, 32.0)  # T40X_config.yaml `N` (joint 4 turns the other way)
# FIGAROH identification.py: "calibration between joint mdh position and robot measure".
# q_joint = T^-1 q_motor + JOINT_OFFSETS_RAD. The logged torques are motor torques in N*m (FIGAROH multiplies
# them by the gear ratios only), so the sidecar gives no torque constants.
JOINT_OFFSETS_RAD = (0.0, -np.pi / 2, np.pi / 2, 0.0, 0.0, 0.0)


def transmission_matrix() -> np.ndarray:
    """T: q_motor = T @ q_joint (rad/rad). Motor 6 drives q5 + q6 (FIGAROH: red_q[5, 4] = N6)."""
    T = np.diag(GEAR_RATIOS)
    T[5, 4] = GEAR_RATIOS[5]
    return T


def transmission() -> dict:
    """The sidecar's `transmission` block: G = T^-1 and the motor readings at the URDF's joint zero."""
    T = transmission_matrix()
    return {"motors": MOTORS,
            "motor_to_joint": (np.linalg.inv(T) + 0.0).tolist(),  # + 0.0: no "-0.0" in the JSON
            "zero_offsets_rad": (-T @ np.array(JOINT_OFFSETS_RAD)).tolist()}


def load_source(directory: str | Path) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(t s, q_motor rad, motor torque as logged) for the whole log."""
    directory = Path(directory)
    qm = read_table(find_source(directory, SOURCE_FILES["position"]), 6)
    tm = read_table(find_source(directory, SOURCE_FILES["torque"]), 6)
    if qm.shape != tm.shape:
        raise LogImportError(f"{directory}: position log {qm.shape} and torque log {tm.shape} differ")
    t = np.arange(qm.shape[0]) / RATE_HZ
    return t, qm, tm


def sidecar(urdf_rel: str, rate_hz: float, description: str) -> dict:
    """The trial sidecar: robot, and the motor-to-joint map as FIGAROH publishes it."""
    return {
        "urdf": urdf_rel,
        "actuated_joints": JOINTS,
        "fixed_joints": {},
        "gravity": [0.0, 0.0, -9.81],
        "ee_frame": "tool0",
        "rate_hz": rate_hz,
        "torque_kind": "measured",
        "transmission": transmission(),
        "source": {"repo": SOURCE_REPO, "commit": SOURCE_COMMIT, "license": "Apache-2.0",
                   "files": [f"examples/staubli_TX40/data/{f}" for f in SOURCE_FILES.values()]},
        "description": description,
    }


def write_trial(path: Path, t: np.ndarray, q_motor: np.ndarray, value: np.ndarray, meta: dict) -> Path:
    """CSV columns: t (s), q_<motor> (rad, motor side), tau_meas_<motor> (N*m, motor side); sidecar beside."""
    header = ["t", *(f"q_{m}" for m in MOTORS), *(f"tau_meas_{m}" for m in MOTORS)]
    return write_trial_csv(path, header, np.column_stack([t, q_motor, value]), meta)


def convert(source: str | Path, out: str | Path,
            windows_s: Sequence[tuple[float, float]] = ((0.0, 9.0),), factor: int = 1,
            urdf: str | Path | None = None, names: Sequence[str] | None = None) -> list[Path]:
    """Write one trial per time window [a, b) s of the log, decimated by `factor` (1 = as recorded)."""
    out = Path(out)
    urdf = Path(urdf) if urdf is not None else Path(source) / ".." / URDF_NAME
    if not urdf.exists():
        raise LogImportError(f"{urdf}: URDF not found (pass --urdf)")
    t, qm, tm = load_source(source)
    if factor < 1:
        raise LogImportError(f"decimation factor must be >= 1, got {factor}")
    qm, tm = decimate(qm, factor), decimate(tm, factor)
    t = t[::factor]
    rate = RATE_HZ / factor
    selections = []  # every window checked before anything is written
    for a, b in windows_s:
        if not (0.0 <= a < b):
            raise LogImportError(f"window {a}:{b} s: need 0 <= start < end")
        sel = (t >= a - 1e-12) & (t < b - 1e-12)
        if sel.sum() < 16:
            raise LogImportError(f"window {a}:{b} s holds {sel.sum()} samples "
                                 f"of a {t[-1] + 1 / rate:.3f} s log")
        selections.append((a, b, sel))
    how = "as recorded" if factor == 1 else f"decimated x{factor} (linear-phase FIR)"
    paths = []
    for i, (a, b, sel) in enumerate(selections):
        name = names[i] if names else f"tx40_{i:02d}"
        desc = (f"Staubli TX40 identification log (FIGAROH), t = {a:g}..{b:g} s of the recording, "
                f"{how} at {rate:g} Hz; motor-side encoder positions and motor torques")
        meta = sidecar(os.path.relpath(urdf.resolve(), out.resolve()), rate, desc)
        paths.append(write_trial(out / f"{name}.csv", t[sel] - t[sel][0], qm[sel], tm[sel], meta))
    return paths


def run(args: argparse.Namespace) -> list[Path]:
    """Import as the options say; LogImportError on a source that cannot be read."""
    return convert(args.source, args.out, args.window or [(0.0, 9.0)], args.decimate, args.urdf)


def add_arguments(p: argparse.ArgumentParser, out: Callable[[str], Path] = Path,
                  factor: Callable[[str], int] = int) -> None:
    """The importer's options (`sparc-quad gap import tx40` and `python -m` this module); `out` and
    `factor` parse --out and --decimate (the command line passes its checked types)."""
    p.add_argument("--source", type=Path, required=True,
                   help="folder with pos_read_data.csv and curr_data.csv (optionally .xz/.gz)")
    p.add_argument("--out", type=out, required=True, help="output folder for the trials")
    p.add_argument("--urdf", type=Path, default=None, help=f"the TX40 URDF (default: SOURCE/../{URDF_NAME})")
    add_decimate_and_window(p, factor, "decimation factor (1: as recorded)", "")


main = importer_main("import_tx40", __doc__, add_arguments, run)


if __name__ == "__main__":
    sys.exit(main())
