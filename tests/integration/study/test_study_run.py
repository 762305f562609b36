"""Study runs on very short trials: records, resumability, atomic writes, failures, CSV, local pool vs
Dask LocalCluster."""

from __future__ import annotations

import csv
import json
import os
import subprocess
import sys

import pytest

from sparc_quad.study import executors
from sparc_quad.study.records import atomic_write_text, code_version, read_record, write_record
from sparc_quad.study.runner import run_study
from sparc_quad.study.spec import parse_spec
from tests.paths import ROOT

TINY = {
    "study": {"seeds": [0]},
    "scenario": {"gait": "raibert", "duration": 0.6, "speed": 0.9},
    "grid": {"spine": ["impedance", "rigid"], "kx": [300, 1200]},
}


def tiny_spec():
    return parse_spec(TINY)


def _strip(rec: dict) -> dict:
    """The parts of a record that must not depend on where or when it ran."""
    m = dict(rec["metrics"])
    for k in list(m):
        if "wall" in k:
            m.pop(k)
    return {"hash": rec["hash"], "config": rec["config"], "status": rec["status"], "metrics": m}


@pytest.fixture(scope="module")
def local_study(tmp_path_factory):
    out = tmp_path_factory.mktemp("study")
    s = run_study(tiny_spec(), out, workers=2, progress=False)
    return out, s


def test_first_run_executes_all(local_study):
    out, s = local_study
    assert (s.trials, s.executed, s.cached, s.failed) == (3, 3, 0, 0)
    summary = json.loads((out / "summary.json").read_text())
    assert (summary["executed"], summary["cached"], summary["failed"]) == (3, 0, 0)
    assert summary["code_version"] == code_version()
    recs = [read_record(p) for p in (out / "trials").glob("*.json")]
    assert len(recs) == 3 and all(r["status"] == "ok" for r in recs)
    assert sorted(summary["hashes"]) == sorted(r["hash"] for r in recs)
    assert not list((out / "trials").glob(".*.tmp"))


def test_rerun_is_cached(local_study):
    out, _ = local_study
    s = run_study(tiny_spec(), out, workers=2, progress=False)
    assert (s.executed, s.cached, s.failed) == (0, 3, 0)
    assert json.loads((out / "summary.json").read_text())["cached"] == 3


def test_partial_record_is_run_again(local_study, tmp_path):
    src, _ = local_study
    out = tmp_path / "copy"
    (out / "trials").mkdir(parents=True)
    paths = sorted((src / "trials").glob("*.json"))
    for p in paths[:2]:
        (out / "trials" / p.name).write_text(p.read_text())
    (out / "trials" / paths[2].name).write_text(paths[2].read_text()[:50])  # a torn write from an old tool
    s = run_study(tiny_spec(), out, workers=0, progress=False)
    assert (s.executed, s.cached) == (1, 2)
    assert _strip(read_record(out / "trials" / paths[2].name)) == _strip(read_record(paths[2]))


def test_csv_has_config_metrics_and_fell(local_study):
    out, _ = local_study
    with open(out / "trials.csv") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == 3
    cols = rows[0].keys()
    for c in ("gait", "spine", "speed", "seed", "duration", "kx", "fell", "status", "hash"):
        assert c in cols
    assert any(c.startswith("m.cot_") for c in cols)
    assert {r["spine"] for r in rows} == {"impedance", "rigid"}
    assert all(r["kx"] == "" for r in rows if r["spine"] == "rigid")


def test_failures_are_recorded_and_counted(tmp_path, monkeypatch):
    def boom(config):
        raise RuntimeError(f"cannot bound at kx={config.get('kx')}")

    monkeypatch.setattr(executors, "trial_function", lambda name=executors.TRIAL: boom)
    s = run_study(tiny_spec(), tmp_path, workers=0, progress=False)
    assert (s.executed, s.failed) == (3, 3)
    recs = [read_record(p) for p in (tmp_path / "trials").glob("*.json")]
    assert all(r["status"] == "failed" and "cannot bound" in r["error"] for r in recs)
    assert json.loads((tmp_path / "summary.json").read_text())["failed"] == 3
    # failures are cached too unless asked to retry
    assert run_study(tiny_spec(), tmp_path, workers=0, progress=False).executed == 0
    assert run_study(tiny_spec(), tmp_path, workers=0, progress=False, retry_failed=True).executed == 3


def test_atomic_write_leaves_old_file_on_error(tmp_path):
    p = tmp_path / "r.json"
    atomic_write_text(p, "old\n")

    class Bad:
        def __str__(self):
            raise ValueError("no")

    with pytest.raises(TypeError):
        write_record(tmp_path, {"hash": "r", "config": {}, "status": "ok", "metrics": {"x": Bad()}})
    assert p.read_text() == "old\n"
    assert [q.name for q in tmp_path.iterdir()] == ["r.json"]


def test_local_pool_sets_one_blas_thread(monkeypatch):
    """Workers start with one BLAS thread; the parent's environment is left as it was."""
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor

    monkeypatch.delenv("OMP_NUM_THREADS", raising=False)
    with executors._blas_env():
        pool = ProcessPoolExecutor(
            1, mp_context=multiprocessing.get_context("spawn"), initializer=executors._init_worker
        )
    with pool:
        env = list(pool.map(os.getenv, executors.BLAS_ENV))
    assert env == ["1"] * len(executors.BLAS_ENV)
    assert "OMP_NUM_THREADS" not in os.environ


def test_dask_local_cluster_gives_the_same_records(local_study, tmp_path):
    distributed = pytest.importorskip("dask.distributed")
    src, _ = local_study
    with distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1", dashboard_address=None
    ) as cluster:
        s = run_study(tiny_spec(), tmp_path, scheduler=cluster.scheduler_address, progress=False)
    assert (s.executed, s.failed) == (3, 0)
    a = {p.name: _strip(read_record(p)) for p in (src / "trials").glob("*.json")}
    b = {p.name: _strip(read_record(p)) for p in (tmp_path / "trials").glob("*.json")}
    assert a == b


def test_cli_run_and_report(local_study, tmp_path):
    src, _ = local_study
    spec = tmp_path / "tiny.toml"
    spec.write_text(
        '[study]\nseeds = [0]\n[scenario]\ngait = "raibert"\nduration = 0.6\nspeed = 0.9\n'
        '[grid]\nspine = ["impedance", "rigid"]\nkx = [300, 1200]\n'
    )
    out = tmp_path / "out"
    (out / "trials").mkdir(parents=True)
    for p in (src / "trials").glob("*.json"):
        (out / "trials" / p.name).write_text(p.read_text())
    r = subprocess.run(
        [
            sys.executable,
            "-m",
            "sparc_quad",
            "study",
            "run",
            str(spec),
            "--out",
            str(out),
            "--no-progress",
            "--report",
        ],
        capture_output=True,
        text=True,
        cwd=ROOT,
        timeout=300,
    )
    assert r.returncode == 0, r.stderr
    assert "executed 0, cached 3, failed 0" in r.stdout
    assert (out / "report" / "cells.csv").exists()
    r = subprocess.run(
        [sys.executable, "-m", "sparc_quad", "study", "report", str(tmp_path / "nothing")],
        capture_output=True,
        text=True,
        cwd=ROOT,
        timeout=120,
    )
    assert r.returncode == 2 and "Traceback" not in r.stderr
