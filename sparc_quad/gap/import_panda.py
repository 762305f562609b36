"""Import the Franka Emika Panda identification log of Gaz et al. (RA-L 2019) into the gap trial format.

Source: github.com/marcocognetti/FrankaEmikaPandaDynModel (GPL-3.0), `matlab/data/Exciting_Traj/
Trajectory_1/rbt_log/`: one exciting trajectory (Fourier series) run for 21 s on a real Panda, 20 544
samples of joint positions (rad), velocities (rad/s) and torques (N*m) measured by the joint torque sensors,
one value per line, sample by sample (7 joints each), and their time stamps (s; median period 1.0 ms, jitter
0.7-8.8 ms). A 7-axis arm with link-side torque sensors: no transmission, no coupled wrist.

The URDF is the Panda of example-robot-data (franka_description's, Apache-2.0), copied from the installed
package into the output folder; the gripper's fingers are fixed at 0 m. Trials are resampled onto a uniform
grid (linear interpolation of each signal at `rate_hz`; the reader and the workflow assume uniform samples).

    python -m sparc_quad.gap.import_panda --source DIR --out DIR [--rate 1000] [--window 0:10 ...]
"""

from __future__ import annotations

import argparse
import shutil
import sys
from collections.abc import Callable, Sequence
from importlib import metadata
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

SOURCE_REPO = "https://github.com/marcocognetti/FrankaEmikaPandaDynModel"
SOURCE_COMMIT = "24d85ce4e648e2e894c832bfeee9b16711eb1a1a"
SOURCE_DIR = "matlab/data/Exciting_Traj/Trajectory_1/rbt_log"
SOURCE_FILES = {"t": "exciting_traj_time.txt", "q": "exciting_traj_positions.txt",
                "dq": "exciting_traj_velocity.txt", "tau": "exciting_traj_torques.txt"}
JOINTS = [f"panda_joint{i}" for i in range(1, 8)]
FIXED = {"panda_finger_joint1": 0.0, "panda_finger_joint2": 0.0}
URDF_NAME = "panda.urdf"


def package_urdf() -> Path:
    """panda.urdf of the installed example-robot-data (its file list; no hard-coded path)."""
    for f in metadata.files("example-robot-data") or []:
        if f.name == URDF_NAME and "panda_description" in f.parts:
            return Path(f.locate())
    raise LogImportError("example-robot-data has no panda_description/urdf/panda.urdf")


def load_source(directory: str | Path) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(t s, q rad, dq rad/s, tau N*m) as logged, (N,) and (N, 7)."""
    directory = Path(directory)
    cols = {k: read_table(find_source(directory, f), 1, delimiter=None, skiprows=0)[:, 0]
            for k, f in SOURCE_FILES.items()}
    t = cols["t"]
    n = len(t)
    out = []
    for k in ("q", "dq", "tau"):
        if len(cols[k]) != 7 * n:
            path = find_source(directory, SOURCE_FILES[k])
            raise LogImportError(f"{path}: {len(cols[k])} values, expected 7 per time stamp ({7 * n})")
        out.append(cols[k].reshape(n, 7))  # sample by sample: the first 7 values are the start pose
    bad = np.nonzero(np.diff(t) <= 0)[0]
    if bad.size:
        raise LogImportError(f"{find_source(directory, SOURCE_FILES['t'])}: time not increasing at line "
                             f"{int(bad[0]) + 2}")
    return t, *out


def resample(t: np.ndarray, x: np.ndarray, rate_hz: float) -> tuple[np.ndarray, np.ndarray]:
    """x (N, n) sampled at t, linearly interpolated onto t[0] + k / rate_hz."""
    tu = t[0] + np.arange(int(np.floor((t[-1] - t[0]) * rate_hz)) + 1) / rate_hz
    return tu, np.column_stack([np.interp(tu, t, x[:, j]) for j in range(x.shape[1])])


def sidecar(rate_hz: float, description: str) -> dict:
    return {"urdf": URDF_NAME, "actuated_joints": JOINTS, "fixed_joints": FIXED,
            "gravity": [0.0, 0.0, -9.81], "rate_hz": rate_hz, "torque_kind": "measured",
            "description": description,
            "source": {"repo": SOURCE_REPO, "commit": SOURCE_COMMIT, "license": "GPL-3.0",
                       "files": [f"{SOURCE_DIR}/{f}" for f in SOURCE_FILES.values()],
                       "urdf": f"example-robot-data {metadata.version('example-robot-data')} "
                               "robots/panda_description/urdf/panda.urdf (Apache-2.0)"}}


def convert(source: str | Path, out: str | Path, windows_s: Sequence[tuple[float, float]] = ((0.0, 21.0),),
            rate_hz: float = 1000.0, factor: int = 1, names: Sequence[str] | None = None) -> list[Path]:
    """One trial per window [a, b) s of the log (time from the first sample), resampled at rate_hz and
    then decimated by `factor`; the URDF is copied beside them."""
    if not rate_hz > 0 or factor < 1:
        raise LogImportError(f"need rate > 0 and decimation >= 1, got {rate_hz}, {factor}")
    out = Path(out)
    t, q, dq, tau = load_source(source)
    tu, x = resample(t, np.column_stack([q, dq, tau]), rate_hz)
    x = decimate(x, factor)
    tu = tu[::factor] - tu[0]
    rate = rate_hz / factor
    todo = []
    for i, (a, b) in enumerate(windows_s):
        if not (0.0 <= a < b):
            raise LogImportError(f"window {a}:{b} s: need 0 <= start < end")
        sel = (tu >= a - 1e-9) & (tu < b - 1e-9)
        if sel.sum() < 16:
            raise LogImportError(f"window {a}:{b} s holds {sel.sum()} samples of a {tu[-1]:.3f} s log")
        todo.append((names[i] if names else f"panda_{i:02d}", a, b, sel))
    out.mkdir(parents=True, exist_ok=True)
    shutil.copyfile(package_urdf(), out / URDF_NAME)
    header = ["t", *(f"{c}_{j}" for c in ("q", "dq", "tau_meas") for j in JOINTS)]
    paths = []
    for name, a, b, sel in todo:
        dec = f", decimated x{factor} (linear-phase FIR)" if factor > 1 else ""
        desc = (f"Franka Emika Panda identification log (Gaz et al. 2019), t = {a:g}..{b:g} s, resampled to "
                f"{rate_hz:g} Hz (linear){dec}; joint positions, velocities, torques from the joint torque "
                "sensors")
        arr = np.column_stack([tu[sel] - tu[sel][0], x[sel]])
        paths.append(write_trial_csv(out / f"{name}.csv", header, arr, sidecar(rate, desc)))
    return paths


def run(args: argparse.Namespace) -> list[Path]:
    """Import as the options say; LogImportError on a source that cannot be read."""
    return convert(args.source, args.out, args.window or [(0.0, 21.0)], args.rate, args.decimate)


def add_arguments(p: argparse.ArgumentParser, out: Callable[[str], Path] = Path,
                  rate: Callable[[str], float] = float, factor: Callable[[str], int] = int) -> None:
    """The importer's options (`sparc-quad gap import panda` and `python -m` this module); `out`, `rate`,
    `factor` parse --out, --rate, --decimate (the command line passes its checked types)."""
    p.add_argument("--source", type=Path, required=True,
                   help="folder with the four exciting_traj_*.txt files (optionally .xz/.gz)")
    p.add_argument("--out", type=out, required=True,
                   help="output folder for the trials and panda.urdf")
    p.add_argument("--rate", type=rate, default=1000.0,
                   help="uniform resampling rate, Hz")
    add_decimate_and_window(p, factor, "decimation factor after resampling", " 21 s")


main = importer_main("import_panda", __doc__, add_arguments, run)


if __name__ == "__main__":
    sys.exit(main())
