"""Where trials run: a local process pool (default) or an existing Dask distributed cluster.

Both run the same picklable `execute(config, version, hash)`, which never raises for a failing trial: it
returns a record with the error, so one bad cell cannot stop a study. Results are yielded as they finish.
"""

from __future__ import annotations

import contextlib
import importlib
import multiprocessing
import os
import threading
import time
import traceback
from collections.abc import Iterator
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait

# one BLAS thread per worker: parallelism comes from the workers, not from threads fighting for cores
BLAS_ENV = {"OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}


class ExecutorUnavailable(RuntimeError):
    """The requested executor cannot be used here (missing extra, unreachable scheduler)."""


TRIAL = "sparc_quad.study.trial:run_trial"  # a study's job: one trial
CALIBRATION = "sparc_quad.study.speed_match:calibrate"  # a matched-speed cell's calibration


def trial_function(name: str = TRIAL):
    """The job function `module:attr` (the study's trial function by default)."""
    module, attr = name.split(":")
    return getattr(importlib.import_module(module), attr)


def execute(config: dict, version: str, trial_hash: str, function: str = TRIAL) -> dict:
    """Run one job (a trial, or a cell's calibration) and return its record (status ok | failed); never
    raises for the job's errors."""
    from sparc_quad.study.records import code_version

    t0 = time.perf_counter()
    rec: dict = {
        "hash": trial_hash,
        "config": config,
        "code_version": version,
        "host": os.uname().nodename,
        "pid": os.getpid(),
    }
    local = code_version()
    try:
        if local != version:
            raise RuntimeError(f"worker code version {local} differs from the study's {version}")
        fn = trial_function(function)
        rec["trial_function"] = f"{fn.__module__}.{fn.__qualname__}"
        metrics = fn(dict(config))
        if not isinstance(metrics, dict):
            raise TypeError(f"trial function returned {type(metrics).__name__}, not a dict")
        rec.update(status="ok", error=None, metrics=metrics)
        if function != TRIAL:
            return rec
        scenario = importlib.import_module("sparc_quad.study.trial").record_scenario(config, metrics)
        if scenario is not None:  # what `sparc-quad bound --scenario <record>` runs again
            rec["scenario"] = scenario
    except Exception as exc:
        rec.update(
            status="failed",
            error=f"{type(exc).__name__}: {exc}",
            traceback=traceback.format_exc(),
            metrics=None,
        )
    rec["wall_s"] = time.perf_counter() - t0
    return rec


def _init_worker() -> None:
    os.environ.update(BLAS_ENV)
    parent = os.getppid()

    def exit_with_parent() -> None:  # a killed study must not leave workers simulating for nobody
        while True:
            time.sleep(2.0)
            if os.getppid() != parent:
                os._exit(1)

    threading.Thread(target=exit_with_parent, daemon=True, name="exit-with-parent").start()


@contextlib.contextmanager
def _blas_env():
    """Children inherit the environment when they start, before they import numpy."""
    old = {k: os.environ.get(k) for k in BLAS_ENV}
    os.environ.update(BLAS_ENV)
    try:
        yield
    finally:
        for k, v in old.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v


def default_workers() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:
        return os.cpu_count() or 1


IN_FLIGHT_PER_WORKER = 2  # trials submitted ahead of the workers: keeps them busy, never the whole grid


def _stop_pool(pool: ProcessPoolExecutor) -> None:
    """Cancel what has not started and end the workers now: a trial in progress is lost (its record is
    never half-written), a Ctrl-C does not wait minutes for it."""
    procs = list(getattr(pool, "_processes", {}).values())
    pool.shutdown(wait=False, cancel_futures=True)
    for proc in procs:
        proc.terminate()
    for proc in procs:
        proc.join(timeout=5.0)


def run_local(jobs: list[tuple[dict, str, str]], workers: int, function: str = TRIAL) -> Iterator[dict]:
    """Run `jobs` (config, version, hash) on `workers` spawned processes; yield records as they finish.

    At most IN_FLIGHT_PER_WORKER x workers trials are submitted at a time and the wait is a short poll: a
    Ctrl-C during `concurrent.futures.wait` over a whole grid's futures could leave their locks held and
    deadlock the pool's shutdown (seen with 100 000 trials). Closing the generator (Ctrl-C) or an error
    ends the workers at once."""
    ctx = multiprocessing.get_context("spawn")
    with _blas_env():
        pool = ProcessPoolExecutor(max_workers=workers, mp_context=ctx, initializer=_init_worker)
    pending: dict = {}
    queue = iter(jobs)
    limit = IN_FLIGHT_PER_WORKER * workers
    try:
        while True:
            while len(pending) < limit:
                job = next(queue, None)
                if job is None:
                    break
                pending[pool.submit(execute, *job, function)] = job
            if not pending:
                break
            done, _ = wait(pending, timeout=0.5, return_when=FIRST_COMPLETED)
            for fut in done:
                cfg, version, h = pending.pop(fut)
                try:
                    rec = fut.result()
                except Exception as exc:  # the worker process died (e.g. killed, out of memory)
                    rec = {"hash": h, "config": cfg, "code_version": version, "status": "failed",
                           "error": f"worker lost: {type(exc).__name__}: {exc}", "metrics": None,
                           "wall_s": None}
                yield rec
    except BaseException:  # GeneratorExit (the caller stopped: Ctrl-C), KeyboardInterrupt, an error
        _stop_pool(pool)
        raise
    pool.shutdown(wait=True)


def run_inline(jobs: list[tuple[dict, str, str]], function: str = TRIAL) -> Iterator[dict]:
    """Run `jobs` one after another in this process (debugging, tests)."""
    for job in jobs:
        yield execute(*job, function)


def _connect(client_class, address: str, timeout_s: float):
    """A Dask client, or ExecutorUnavailable when the scheduler refuses the connection or does not answer
    within `timeout_s` (a listener that accepts and stays silent kept `Client` waiting for minutes)."""
    box: dict = {}

    def connect() -> None:
        try:
            box["client"] = client_class(address, timeout=timeout_s)
        except BaseException as exc:
            box["error"] = exc

    thread = threading.Thread(target=connect, daemon=True, name="dask-connect")
    thread.start()
    thread.join(timeout_s + 5.0)
    if thread.is_alive():
        raise ExecutorUnavailable(f"--scheduler {address}: no answer within {timeout_s + 5.0:g} s (is it a "
                                  "Dask scheduler?)")
    if "error" in box:
        exc = box["error"]
        raise ExecutorUnavailable(f"--scheduler {address}: cannot connect ({type(exc).__name__}: {exc})")
    return box["client"]


def run_dask(
    jobs: list[tuple[dict, str, str]], address: str, connect_timeout_s: float = 30.0, function: str = TRIAL
) -> Iterator[dict]:
    """Submit `jobs` to the Dask scheduler at `address`; yield records as they finish. Connects at the call
    (not at the first record): a scheduler that cannot be reached is known before the study writes
    anything."""
    try:
        from dask.distributed import Client, as_completed
    except ImportError:
        raise ExecutorUnavailable(
            "--scheduler needs Dask distributed: pip install 'sparc-quad[study]'"
        ) from None
    return _dask_records(_connect(Client, address, connect_timeout_s), as_completed, jobs, function)


def _dask_records(client, as_completed, jobs: list[tuple[dict, str, str]], function: str = TRIAL
                  ) -> Iterator[dict]:
    futures: dict = {}
    try:
        for cfg, version, h in jobs:
            fut = client.submit(execute, cfg, version, h, function, key=f"sparc-job-{h}", pure=False)
            futures[fut] = (cfg, version, h)
        for fut in as_completed(list(futures)):
            cfg, version, h = futures.pop(fut)
            try:
                yield fut.result()
            except Exception as exc:  # the worker died under the trial (KilledWorker) or the graph failed
                yield {
                    "hash": h,
                    "config": cfg,
                    "code_version": version,
                    "status": "failed",
                    "error": f"dask: {type(exc).__name__}: {exc}",
                    "metrics": None,
                    "wall_s": None,
                }
            fut.release()
    finally:
        for fut in futures:
            fut.cancel()
        client.close()
