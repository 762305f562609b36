"""Run a study: expand the spec, skip trials whose record exists, execute the rest, write the tables.

DIR/trials/<hash>.json  one record per trial (config, code version, status, error, metrics, strides)
DIR/calibrations/<hash>.json  one per matched-speed cell (`speed_match`): run before the cell's trials,
                        each of which then runs at the calibrated input (its record says which)
DIR/trials.csv          one row per trial of this spec (config columns, fell, every scalar metric)
DIR/summary.json        counts (trials, executed, cached, failed) and the hashes of this spec's trials
DIR/spec.toml           the spec that was run
"""

from __future__ import annotations

import json
import logging
import time
from dataclasses import dataclass, field
from pathlib import Path

from sparc_quad.study import executors
from sparc_quad.study.records import (
    atomic_write_text,
    code_version,
    git_describe,
    read_record,
    trial_hash,
    write_csv,
    write_record,
)
from sparc_quad.study.spec import Spec

log = logging.getLogger(__name__)


class StudyWriteError(OSError):
    """A record or table that could not be written (a full disk, a folder that went away): one line naming
    the path; the records already written stay whole."""


@dataclass
class RunSummary:
    trials: int = 0
    executed: int = 0
    cached: int = 0
    failed: int = 0  # failed among this spec's trials (executed now or cached from before)
    failed_now: int = 0
    interrupted: bool = False
    wall_s: float = 0.0
    hashes: list[str] = field(default_factory=list)
    calibrations: int = 0  # matched-speed cells calibrated by this run (speed_match)


def plan(spec: Spec, version: str | None = None) -> list[tuple[dict, str]]:
    version = version or code_version()
    return [(cfg, trial_hash(cfg, version)) for cfg in spec.trials()]


def run_study(
    spec: Spec,
    out: Path,
    workers: int | None = None,  # None: one per core; 0: in this process, one after another
    scheduler: str | None = None,
    retry_failed: bool = False,
    progress: bool = True,
    scheduler_timeout_s: float = 30.0,
) -> RunSummary:
    """Execute the missing trials of `spec` into `out`; always leaves trials.csv and summary.json
    consistent with the records on disk (also after Ctrl-C, which re-raises KeyboardInterrupt)."""
    out = Path(out)
    trials_dir = out / "trials"
    version = code_version()
    planned = plan(spec, version)
    summary = RunSummary(trials=len(planned), hashes=[h for _, h in planned])
    records: dict[str, dict] = {}
    todo: list[tuple[dict, str, str]] = []
    for cfg, h in planned:
        rec = read_record(trials_dir / f"{h}.json")
        if rec is not None and (rec["status"] == "ok" or not retry_failed):
            records[h] = rec
            summary.cached += 1
        else:
            todo.append((cfg, version, h))
    t0 = time.perf_counter()

    def stream_of(jobs: list, function: str = executors.TRIAL):
        if not jobs:
            return iter(())
        if scheduler:
            return executors.run_dask(jobs, scheduler, connect_timeout_s=scheduler_timeout_s,
                                      function=function)
        if workers == 0:
            return executors.run_inline(jobs, function)
        n = workers or executors.default_workers()
        return executors.run_local(jobs, max(1, min(n, len(jobs))), function)

    cells = _cells_to_calibrate(todo, out / "calibrations", version)
    summary.calibrations = len(cells["todo"])
    # the executor is ready (a scheduler reached): only now is anything written
    first = stream_of(cells["todo"], executors.CALIBRATION) if cells["todo"] else None
    stream = stream_of([_with_calibration(job, cells) for job in todo]) if first is None else None
    trials_dir.mkdir(parents=True, exist_ok=True)
    if spec.source:
        try:
            atomic_write_text(out / "spec.toml", Path(spec.source).read_text())
        except OSError:
            pass
    bar = None
    try:
        if first is not None:
            _calibrate(first, cells, out / "calibrations", spec.name, progress)
            stream = stream_of([_with_calibration(job, cells) for job in todo])
        if progress and todo:
            from tqdm import tqdm

            bar = tqdm(total=len(todo), unit="trial", desc=spec.name, mininterval=2.0, smoothing=0.1)
        for rec in stream:
            rec["config"] = {k: v for k, v in rec["config"].items() if k != "matched"}
            _save(trials_dir, rec)
            records[rec["hash"]] = rec
            summary.executed += 1
            if rec["status"] != "ok":
                summary.failed_now += 1
                log.warning("trial %s failed: %s", rec["hash"], rec.get("error"))
            if bar is not None:
                bar.set_postfix(failed=summary.failed_now, refresh=False)
                bar.update(1)
    except KeyboardInterrupt:
        summary.interrupted = True
        raise
    finally:
        _close(stream, bar)
        summary.wall_s = time.perf_counter() - t0
        summary.failed = sum(1 for r in records.values() if r["status"] != "ok")
        try:
            finish(
                out,
                spec,
                version,
                summary,
                [records[h] for _, h in planned if h in records],
                workers=None if scheduler else (executors.default_workers() if workers is None
                                                else workers),
                scheduler=scheduler,
            )
        except OSError as exc:  # the tables are rewritten from the records by the next run
            raise StudyWriteError(exc.errno, f"cannot write the tables in {out} ({exc.strerror or exc})") \
                from None
    return summary


def _save(folder: Path, rec: dict) -> None:
    """Write one record; a full disk or a vanished folder is one line naming the folder."""
    try:
        write_record(folder, rec)
    except OSError as exc:
        raise StudyWriteError(exc.errno, f"cannot write a record in {folder} ({exc.strerror or exc})") \
            from None


def _close(stream, bar) -> None:
    """End an executor's stream (its workers stop now) and its progress bar."""
    close = getattr(stream, "close", None)
    if close is not None:
        close()
    if bar is not None:
        bar.close()


def _cells_to_calibrate(todo: list, folder: Path, version: str) -> dict:
    """The matched-speed cells among the trials to run: their calibration records found in `folder`
    (`done`: cell hash -> result) and the calibrations still to run (`todo`: jobs)."""
    from sparc_quad.study.speed_match import cell_config, is_matched

    done: dict[str, dict] = {}
    jobs: dict[str, tuple] = {}
    of_trial: dict[str, str] = {}
    for cfg, _, h in todo:
        if not is_matched(cfg) or cfg.get("matched") is not None:
            continue
        cell = cell_config(cfg)
        ch = trial_hash(cell, version)
        of_trial[h] = ch
        if ch in done or ch in jobs:
            continue
        rec = read_record(folder / f"{ch}.json")
        if rec is not None and rec["status"] == "ok":
            done[ch] = rec["metrics"]
        else:
            jobs[ch] = (cell, version, ch)
    return {"done": done, "todo": list(jobs.values()), "of_trial": of_trial, "failed": {}}


def _calibrate(stream, cells: dict, folder: Path, name: str, progress: bool) -> None:
    """Run the cells' calibrations, writing each record as it comes."""
    folder.mkdir(parents=True, exist_ok=True)
    bar = None
    if progress:
        from tqdm import tqdm

        bar = tqdm(total=len(cells["todo"]), unit="cell", desc=f"{name}: calibrating speed", mininterval=2.0)
    try:
        for rec in stream:
            _save(folder, rec)
            if rec["status"] == "ok":
                cells["done"][rec["hash"]] = rec["metrics"]
            else:
                cells["failed"][rec["hash"]] = rec.get("error")
                log.warning("calibration %s failed: %s", rec["hash"], rec.get("error"))
            if bar is not None:
                bar.update(1)
    finally:
        _close(stream, bar)


def _with_calibration(job: tuple, cells: dict) -> tuple:
    """A trial job with its cell's calibration passed in (`matched`); a failed calibration is passed as
    such and the trial fails naming it."""
    cfg, version, h = job
    ch = cells["of_trial"].get(h)
    if ch is None:
        return job
    if ch in cells["done"]:
        return {**cfg, "matched": cells["done"][ch]}, version, h
    return {**cfg, "matched": {"failed": cells["failed"].get(ch, "not run")}}, version, h


def finish(
    out: Path, spec: Spec, version: str, s: RunSummary, records: list[dict], workers, scheduler
) -> None:
    write_csv(out / "trials.csv", records)
    doc = {
        "name": spec.name,
        "spec": spec.source,
        "code_version": version,
        "git_describe": git_describe(),
        "trials": s.trials,
        "done": len(records),
        "executed": s.executed,
        "cached": s.cached,
        "failed": s.failed,
        "failed_this_run": s.failed_now,
        "calibrations_run": s.calibrations,
        "interrupted": s.interrupted,
        "wall_s": round(s.wall_s, 3),
        "trials_per_minute": round(60.0 * s.executed / s.wall_s, 3) if s.executed and s.wall_s > 0 else None,
        "workers": workers,
        "scheduler": scheduler,
        "hashes": s.hashes,
    }
    atomic_write_text(out / "summary.json", json.dumps(doc, indent=1) + "\n")
