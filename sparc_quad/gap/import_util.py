"""Shared steps of the real-log importers (`import_tx40`, `import_panda`): find a source file that may
be compressed, read a numeric table with a clear error, write a trial CSV + sidecar, never half-written."""

from __future__ import annotations

import argparse
import json
import os
import sys
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np


class LogImportError(ValueError):
    """Bad source data; the message names the file."""


def find_source(directory: Path, name: str) -> Path:
    """`name` in `directory`, or its .xz / .gz compressed copy (numpy reads both)."""
    for suffix in ("", ".xz", ".gz"):
        p = directory / (name + suffix)
        if p.exists():
            return p
    return directory / name


def read_table(path: Path, ncols: int, delimiter: str | None = ",", skiprows: int = 1) -> np.ndarray:
    """A numeric table of `ncols` columns and >= 16 finite rows (one column is returned as (N, 1))."""
    if not path.exists():
        raise LogImportError(f"{path}: file not found")
    try:
        arr = np.loadtxt(path, delimiter=delimiter, skiprows=skiprows, ndmin=2)
    except (ValueError, OSError, EOFError) as exc:
        raise LogImportError(f"{path}: not a {ncols}-column numeric table: {exc}") from exc
    if arr.shape[1] != ncols or arr.shape[0] < 16:
        raise LogImportError(f"{path}: expected >= 16 rows x {ncols} columns, got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        row = int(np.argwhere(~np.isfinite(arr))[0, 0]) + 1
        raise LogImportError(f"{path}: non-finite value in data row {row}")
    return arr


def write_trial_csv(path: Path, header: list[str], arr: np.ndarray, meta: dict, fmt: str = "%.8g") -> Path:
    """CSV + JSON sidecar, written under temporary names and renamed (no half-written trial on failure)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp_csv, tmp_json = path.with_suffix(".csv.part"), path.with_suffix(".json.part")
    np.savetxt(tmp_csv, arr, delimiter=",", header=",".join(header), comments="", fmt=fmt)
    tmp_json.write_text(json.dumps(meta, indent=2) + "\n")
    os.replace(tmp_csv, path)
    os.replace(tmp_json, path.with_suffix(".json"))
    return path


def decimate(x: np.ndarray, factor: int) -> np.ndarray:
    """Anti-aliased decimation with a linear-phase FIR (scipy.signal.resample_poly: Kaiser window, no delay,
    unit DC gain; ends padded with a fitted line). Not `signal.decimate`'s IIR default: its Chebyshev-I
    filter run forward-backward has a DC gain of 0.989, a 1.1 % error on every position."""
    if factor == 1:
        return x
    from scipy import signal  # here, not at import: `sparc-quad gap import --help` loads no scipy

    return signal.resample_poly(x, 1, factor, axis=0, padtype="line")


def time_window(text: str) -> tuple[float, float]:
    """argparse type for `--window START:END` (seconds)."""
    a, sep, b = text.partition(":")
    try:
        if not sep:
            raise ValueError
        return float(a), float(b)
    except ValueError:
        raise argparse.ArgumentTypeError(f"window must be START:END in seconds, got {text!r}") from None


def add_decimate_and_window(p: argparse.ArgumentParser, factor: Callable[[str], int], decimate_help: str,
                            whole_log: str) -> None:
    """`--decimate` and `--window`, spelled once for every importer; `whole_log` names the default window."""
    p.add_argument("--decimate", type=factor, default=1, help=decimate_help)
    p.add_argument("--window", type=time_window, action="append", default=None, metavar="START:END",
                   help=f"time window in s (repeatable; default the whole{whole_log} log)")


def importer_main(module: str, doc: str, add_arguments: Callable[[argparse.ArgumentParser], None],
                  run: Callable[[argparse.Namespace], list[Path]]) -> Callable[..., int]:
    """The `main(argv=None)` of `python -m sparc_quad.gap.<module>` (`doc`'s first line is its description):
    parse, import, print the trial paths; 2 on a LogImportError. One for every importer, which then only
    says its options and how to run them (the same two are `sparc-quad gap import ...`)."""
    def main(argv: Sequence[str] | None = None) -> int:
        p = argparse.ArgumentParser(prog=f"python -m sparc_quad.gap.{module}", description=doc.split("\n")[0])
        add_arguments(p)
        try:
            paths = run(p.parse_args(argv))
        except LogImportError as exc:
            print(f"error: {exc}", file=sys.stderr)
            return 2
        for path in paths:
            print(path)
        return 0
    return main
