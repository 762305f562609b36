"""Trial records on disk: one JSON file per trial, named by a hash of its config and the code version.

A record is written atomically (temporary file in the same folder, then os.replace), so a killed study
leaves whole records or none, and a rerun executes only the trials whose record is missing. The code
version hashes the source files a trial's result can depend on (the simulation, the controllers, the
robots), not the study's own report/CLI code, so improving a plot does not invalidate a finished study.
"""

from __future__ import annotations

import csv
import gzip
import hashlib
import io
import json
import os
import tempfile
from collections.abc import Iterable
from pathlib import Path

from sparc_quad.jsonfmt import jsonable
from sparc_quad.provenance import (  # noqa: F401  (re-exported: the study's names)
    CODE_DIRS,
    NOT_TRIAL_CODE,
    ROOT,
    code_version,
    git_describe,
    package_version,
    trial_source_files,
)

RECORD_VERSION = 1


def canonical(config: dict) -> str:
    """The config as sorted-key JSON: equal configs give equal text whatever their key order."""
    return json.dumps(config, sort_keys=True, separators=(",", ":"), allow_nan=False)


def trial_hash(config: dict, version: str) -> str:
    return hashlib.sha256(f"{version}\n{canonical(config)}".encode()).hexdigest()[:20]


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def atomic_write_text(path: Path, text: str) -> None:
    """Write `text` to `path` whole or not at all (tmp file in the same folder + os.replace)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        os.fchmod(fd, 0o666 & ~_umask())  # mkstemp makes 0600; a study's files are for everyone who reads it
        with os.fdopen(fd, "w") as f:
            f.write(text)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except FileNotFoundError:
            pass
        raise


def write_record(trials_dir: Path, record: dict) -> Path:
    path = Path(trials_dir) / f"{record['hash']}.json"
    atomic_write_text(path, json.dumps(jsonable(record), indent=1, allow_nan=False) + "\n")
    return path


def read_record(path: Path) -> dict | None:
    """A record (`<hash>.json`, or gzip-compressed `<hash>.json.gz` as committed studies keep them), or None
    if the file is not a whole record (then the trial is run again)."""
    path = Path(path)
    if path.suffix == ".json" and not path.exists() and path.with_suffix(".json.gz").exists():
        path = path.with_suffix(".json.gz")  # a committed study: re-running it into its folder runs nothing
    try:
        raw = gzip.decompress(path.read_bytes()) if path.suffix == ".gz" else path.read_bytes()
        rec = json.loads(raw.decode("utf-8"))
    except (OSError, ValueError, EOFError):
        return None
    if not isinstance(rec, dict) or "hash" not in rec or "config" not in rec or "status" not in rec:
        return None
    return rec


def load_records(trials_dir: Path) -> list[dict]:
    d = Path(trials_dir)
    if not d.is_dir():
        return []
    out = []
    for p in sorted([*d.glob("*.json"), *d.glob("*.json.gz")]):
        rec = read_record(p)
        if rec is not None:
            out.append(rec)
    return out


def flatten(d: dict, prefix: str = "") -> dict:
    """Nested metrics as flat columns: {"a": {"b": 1}} -> {"a.b": 1}; lists become JSON text."""
    out: dict = {}
    for k, v in d.items():
        name = f"{prefix}{k}"
        if isinstance(v, dict):
            out.update(flatten(v, f"{name}."))
        elif isinstance(v, list | tuple):
            out[name] = json.dumps(jsonable(v))
        else:
            out[name] = v
    return out


CONFIG_FIRST = ("gait", "spine", "speed", "slope", "seed", "duration")


def records_table(records: Iterable[dict]) -> tuple[list[str], list[dict]]:
    """(columns, rows): config columns first, then status/error, then every metric (per-stride lists
    stay in the JSON records). Each record is read as its JSON file holds it, so a trial run in this
    call (NaN, numpy scalars, tuples in memory) gives the same row as the same trial read from disk."""
    rows = []
    cfg_keys: set[str] = set()
    metric_keys: set[str] = set()
    for rec in records:
        rec = json.loads(json.dumps(jsonable(rec), allow_nan=False))
        cfg = rec["config"]
        metrics = {k: v for k, v in (rec.get("metrics") or {}).items() if k != "strides"}
        flat = flatten(metrics)
        cfg_keys.update(cfg)
        metric_keys.update(flat)
        row = {
            **cfg,
            "hash": rec["hash"],
            "status": rec["status"],
            "error": rec.get("error") or "",
            "wall_s": rec.get("wall_s"),
            "n_strides": len((rec.get("metrics") or {}).get("strides") or []),
        }
        row.update({f"m.{k}": v for k, v in flat.items()})
        if "fell" in flat:
            row["fell"] = flat["fell"]
        rows.append(row)
    cfg_cols = [k for k in CONFIG_FIRST if k in cfg_keys] + sorted(cfg_keys - set(CONFIG_FIRST))
    cols = [*cfg_cols, "fell", "status", "error", "hash", "wall_s", "n_strides"]
    cols += [f"m.{k}" for k in sorted(metric_keys) if k != "fell"]
    rows.sort(key=lambda r: tuple(str(r.get(c, "")) for c in cfg_cols))
    return cols, rows


def write_csv(path: Path, records: Iterable[dict]) -> Path:
    cols, rows = records_table(records)
    buf = io.StringIO(newline="")
    w = csv.DictWriter(buf, fieldnames=cols, extrasaction="ignore")
    w.writeheader()
    for r in rows:
        w.writerow({c: ("" if r.get(c) is None else r.get(c)) for c in cols})
    atomic_write_text(Path(path), buf.getvalue())
    return Path(path)
