"""The hostile-input table of issue 32, through the real command line: every class of input the tools must
refuse, one process per case (`python -m sparc_quad ...`, a timeout marks a hang), each ending in exit 2
(1 for a full disk) with one line naming the problem, no traceback, and nothing created or half-written.

One row per case; `REFERENCED` names the tests elsewhere that cover a class further (the in-process tables
of every option and every gap input, Ctrl-C, which ends in 130, not 2). `test_every_class_is_covered`
keeps each class of the issue in the table. About 30 processes of 1-3 s each.

The one line: the last non-empty line of stderr names the problem, and no other line is printed, except
where a row allows one: a typo's error line comes first with one short usage line after it (the issue's
"the error line first and a short usage after it"), and python-can logs its own warning when the kvaser
driver's library is missing."""

from __future__ import annotations

import json
import os
import shutil
import socket
import subprocess
import sys
import threading
from collections.abc import Callable
from dataclasses import dataclass, field
from functools import cache
from pathlib import Path

import pytest

from tests.gap_helpers import copy_trial, edit_meta
from tests.paths import ROOT

CLASSES = ("study size", "per-trial values in a study spec", "interrupts", "silent Dask scheduler",
           "full disk", "gap inputs", "CAN interfaces", "typo'd options")
TIMEOUT_S = 60.0
USAGE = r"usage: sparc-quad .*--help lists every option.*"


@dataclass
class Row:
    cls: str
    name: str
    argv: list[str]  # after `python -m sparc_quad`; {tmp}, {trial}, {port} are filled in
    says: str  # what the one line must hold
    code: int = 2
    setup: Callable[[Path, Path], None] | None = None  # (tmp, trial) -> writes the bad input
    extra: list[str] = field(default_factory=list)  # regexes of the other lines a row may print
    disk: bool = False  # run on a full file system: a 12 kB tmpfs mounted at {tmp}/disk


def _write(name: str, text: str | bytes) -> Callable[[Path, Path], None]:
    def setup(tmp: Path, trial: Path) -> None:
        p = tmp / name
        p.write_bytes(text) if isinstance(text, bytes) else p.write_text(text)
    return setup


def _plant(edit) -> Callable[[Path, Path], None]:
    """A copy of the trial's nominal plant file as plant.json, edited."""
    def setup(tmp: Path, trial: Path) -> None:
        d = json.loads(Path(json.loads(trial.with_suffix(".json").read_text())["plant"]).read_text())
        (tmp / "plant.json").write_text(edit(d))
    return setup


def _with_param(d: dict, key: str, value) -> str:
    next(e for e in d["effects"] if key in e["params"])["params"][key] = value
    return json.dumps(d)  # NaN as the bare token, as a careless tool writes it


def _cut_rows(tmp: Path, trial: Path) -> None:
    lines = trial.read_text().splitlines()
    trial.write_text("\n".join(lines[:200] + lines[700:]) + "\n")


def _fifo(tmp: Path, trial: Path) -> None:
    trial.unlink()
    os.mkfifo(trial)


SPEC = '[scenario]\ngait = "raibert"\nduration = 1.5\n'
STUDY = ["study", "run", "{tmp}/s.toml", "--out", "{tmp}/o"]
GAP = ["gap", "run", "{trial}", "--no-plots", "--out", "{tmp}/zz/a/out"]
PLANT = [*GAP, "--plant", "{tmp}/plant.json"]
SCAN = ["motors", "scan", "--timeout", "0.1", "--can-interface"]
KX_1000 = ", ".join(str(100 + i) for i in range(1000))


def _spec(text: str) -> Callable[[Path, Path], None]:
    return _write("s.toml", text)


ROWS = [
    # study size: sized before it is built (a grid of 10^7 trials would take gigabytes)
    Row("study size", "huge grid", STUDY, "more than 100000",
        setup=_spec(f"[study]\nseeds = 10000\n[grid]\nkx = [{KX_1000}]\n")),
    Row("study size", "huge seeds", STUDY, "study.seeds", setup=_spec("[study]\nseeds = 1000000000\n")),
    Row("study size", "days of trials without --yes", [*STUDY, "--workers", "1"], "--yes",
        setup=_spec(f"[study]\nseeds = 10\n[scenario]\nduration = 10.0\n[grid]\nkx = [{KX_1000}]\n"
                    "dx = [2, 4, 6, 8, 10]\n")),
    # per-trial values: the ranges `bound` checks (one table, sparc_quad.scenario.model)
    *[Row("per-trial values in a study spec", name, STUDY, says, setup=_spec(text)) for name, text, says in (
        ("k_x 1e12 N/m", "[scenario]\nkx = 1e12\n", "scenario.kx: must be in [0, 5000] N/m"),
        ("k_x 1e12 N/m in the grid", "[grid]\nkx = [500, 1e12]\n", "grid.kx"),
        ("duration 1e-9 s", "[scenario]\nduration = 1e-9\n", "scenario.duration: must be in [0.001, 600]"),
        ("duration 601 s", "[scenario]\nduration = 601\n", "scenario.duration"))],
    # a scheduler that accepts the connection and never answers (the listener: the `silent` fixture)
    Row("silent Dask scheduler", "accepts, never answers",
        [*STUDY, "--no-progress", "--scheduler", "tcp://127.0.0.1:{port}", "--scheduler-timeout", "2"],
        "127.0.0.1:{port}", setup=_spec(SPEC)),
    # a full disk: one line, exit 1, the records written before are whole, no half-written output kept
    Row("full disk", "study records",
        ["study", "run", "{tmp}/s.toml", "--out", "{tmp}/disk/o", "--workers", "1", "--no-progress"],
        "No space left on device", code=1, disk=True,
        setup=_spec('[study]\nseeds = 6\n[scenario]\ngait = "raibert"\nduration = 1.5\n')),
    Row("full disk", "gap synth trials", ["gap", "synth", "--periods", "1", "--period", "1", "--out",
                                          "{tmp}/disk/g"], "No space left on device", code=1, disk=True),
    # gap inputs (every case in-process: tests/sparc_quad/gap/test_gap_hostile_inputs.py)
    Row("gap inputs", "plant file not UTF-8", [*GAP, "--plant", "{tmp}/p.json"], "not UTF-8",
        setup=_write("p.json", b"\xff\xfe{}")),
    Row("gap inputs", "plant effects not a list", PLANT, "effects must be a list",
        setup=_plant(lambda d: json.dumps({**d, "effects": {}}))),
    Row("gap inputs", "plant parameter NaN", PLANT, "must be finite",
        setup=_plant(lambda d: _with_param(d, "tau_c_nm", float("nan")))),
    Row("gap inputs", "negative rotor inertia", PLANT, "inertia_kg_m2 (rotor_inertia) -1e+09",
        setup=_plant(lambda d: _with_param(d, "inertia_kg_m2", -1e9))),
    Row("gap inputs", "sidecar gravity 1e300", GAP, "gravity",
        setup=lambda tmp, trial: edit_meta(trial, gravity=[0, 0, -1e300])),
    Row("gap inputs", "rows cut from the middle", GAP, "time jumps from", setup=_cut_rows),
    Row("gap inputs", "a FIFO as the trial", GAP, "not a regular file", setup=_fifo),
    Row("gap inputs", "no such trial, nested --out", ["gap", "run", "{tmp}/nosuch.csv", "--out",
                                                      "{tmp}/zz/a/out"], "file not found"),
    # every python-can interface the CLI offers opens or gives one line
    Row("CAN interfaces", "kvaser without its driver", [*SCAN, "kvaser", "--can-channel", "0"],
        "cannot open CAN bus kvaser:0", extra=[r".* can\.kvaser WARNING: .*"]),
    Row("CAN interfaces", "socketcand without host and port", [*SCAN, "socketcand", "--can-channel", "can0"],
        "--can-option KEY=VALUE"),
    # typos: the error first, "did you mean", one short usage line
    Row("typo'd options", "option", ["bound", "--kxx", "500", "--out", "{tmp}/o"], "did you mean --kx?",
        extra=[USAGE]),
    Row("typo'd options", "option before a positional",
        ["study", "run", "--workrs", "2", "{tmp}/s.toml", "--out", "{tmp}/o"], "did you mean --workers?",
        setup=_spec(SPEC), extra=[USAGE]),
    Row("typo'd options", "gap action", ["gap", "synthh", "--out", "{tmp}/o"], "did you mean synth?",
        extra=[USAGE]),
]

# tests elsewhere that cover a class further (Ctrl-C ends in 130, so it is no row of this table)
INTERRUPT = "tests/integration/cli/test_cli_interrupt.py::"
LIMITS = "tests/integration/test_study_limits.py::"
GAP_INPUTS = "tests/sparc_quad/gap/test_gap_hostile_inputs.py::"
CLI_TABLE = "tests/sparc_quad/cli/test_hostile_inputs.py::"
REFERENCED = {
    "interrupts": [INTERRUPT + "test_ctrl_c_exits_130_and_keeps_the_previous_result",
                   INTERRUPT + "test_ctrl_c_during_gap_workflow",
                   LIMITS + "test_ctrl_c_of_a_large_study_exits_130_with_whole_records"],
    "full disk": [LIMITS + "test_a_full_disk_is_one_line_and_the_records_stay_whole"],
    "gap inputs": [GAP_INPUTS + "test_hostile_input_is_one_line_exit_2_nothing_created",
                   GAP_INPUTS + "test_missing_trial_creates_no_folders"],
    "CAN interfaces": [CLI_TABLE + "test_every_can_interface_opens_or_gives_one_line"],
    "typo'd options": [CLI_TABLE + "test_hostile_input_is_refused_in_one_line",
                       "tests/sparc_quad/cli/test_parser.py::test_a_near_miss_is_named"],
}


@pytest.fixture(scope="module")
def good_trial(tmp_path_factory) -> Path:
    from sparc_quad.gap.synth import synth

    res = synth(tmp_path_factory.mktemp("good"), [], seed=2, n_trials=1, periods=1, period_s=1.0)
    return res["trials"][0]


@pytest.fixture
def silent():
    """A TCP listener that accepts every connection and says nothing; yields its port."""
    server = socket.socket()
    server.bind(("127.0.0.1", 0))
    server.listen(8)
    server.settimeout(0.2)
    held, stop = [], threading.Event()

    def accept() -> None:
        while not stop.is_set():
            try:
                held.append(server.accept()[0])
            except TimeoutError:
                continue

    thread = threading.Thread(target=accept, daemon=True)
    thread.start()
    yield server.getsockname()[1]
    stop.set()
    thread.join()
    for conn in held:
        conn.close()
    server.close()


@cache
def _mount_prefix() -> tuple[str, ...] | None:
    """`unshare` into a private mount namespace (as root, or in a user namespace), or None."""
    if shutil.which("unshare") is None:
        return None
    for prefix in (("unshare", "-m"), ("unshare", "-rm")):
        probe = subprocess.run([*prefix, "sh", "-c", "mount -t tmpfs -o size=4k tmpfs /mnt 2>/dev/null || "
                                "mount -t tmpfs -o size=4k tmpfs /tmp"], capture_output=True, timeout=30)
        if probe.returncode == 0:
            return prefix
    return None


def _tree(root: Path) -> set[str]:
    return {str(p.relative_to(root)) for p in root.rglob("*")}


def _run(row: Row, tmp: Path, trial: Path, port: int | None) -> subprocess.CompletedProcess:
    fill = {"tmp": str(tmp), "trial": str(trial), "port": str(port)}
    argv = [a.format(**fill) for a in row.argv]
    cmd = [sys.executable, "-m", "sparc_quad", *argv]
    if row.disk:
        prefix = _mount_prefix()
        if prefix is None:
            pytest.skip("no private mount namespace here for a full tmpfs (in-process: test_study_limits)")
        (tmp / "disk").mkdir()
        (tmp / "seen").mkdir()
        script = ('mount -t tmpfs -o size=12k tmpfs "$1/disk" || exit 99; shift; "$@"; rc=$?; '
                  f'cp -a "{tmp}/disk/." "{tmp}/seen/"; exit $rc')
        cmd = [*prefix, "sh", "-c", script, "sh", str(tmp), *cmd]
    try:
        return subprocess.run(cmd, cwd=tmp, capture_output=True, text=True, timeout=TIMEOUT_S,
                              env={**os.environ, "PYTHONPATH": str(ROOT)})
    except subprocess.TimeoutExpired:
        pytest.fail(f"{row.cls} / {row.name}: no answer within {TIMEOUT_S:g} s (a hang)")


@pytest.mark.parametrize("row", ROWS, ids=[f"{r.cls}: {r.name}" for r in ROWS])
def test_hostile_input_ends_in_one_line(row, tmp_path, good_trial, request):
    import re

    port = request.getfixturevalue("silent") if "{port}" in " ".join(row.argv) else None
    if port is not None:
        pytest.importorskip("distributed")
    trial = copy_trial(good_trial, tmp_path, "trial")
    if row.setup:
        row.setup(tmp_path, trial)
    before = _tree(tmp_path)
    res = _run(row, tmp_path, trial, port)
    assert res.returncode != 99, "the tmpfs could not be mounted"
    err = res.stderr
    assert "Traceback" not in err + res.stdout and "internal error" not in err, err[-3000:]
    assert res.returncode == row.code, (res.returncode, err[-3000:])
    lines = [line for line in err.splitlines() if line.strip()]
    says = row.says.format(port=port)
    problem = [line for line in lines if says in line]
    assert len(problem) == 1 and problem[0].startswith("sparc-quad "), err
    others = [line for line in lines if line is not problem[0]]
    assert all(any(re.fullmatch(x, line) for x in row.extra) for line in others), err
    if not row.extra:
        assert lines == problem, err  # the one line, and the last
    if row.disk:  # what the full disk holds: no temporary or partial folder, every record whole
        seen = tmp_path / "seen"
        assert not [p for p in seen.rglob("*") if ".tmp-" in p.name or ".partial-" in p.name], _tree(seen)
        for rec in seen.rglob("trials/*.json"):
            json.loads(rec.read_text())
    else:  # refused before any work: nothing created
        assert _tree(tmp_path) == before, sorted(_tree(tmp_path) - before)


def test_every_class_is_covered():
    """Each class of the issue has a row here; the tests it references exist."""
    import ast

    assert {r.cls for r in ROWS} | set(REFERENCED) == set(CLASSES)
    assert {r.cls for r in ROWS} >= set(CLASSES) - {"interrupts"}  # Ctrl-C is exit 130: referenced
    for refs in REFERENCED.values():
        for ref in refs:
            path, name = ref.split("::")
            tree = ast.parse((ROOT / path).read_text())
            assert name in {n.name for n in tree.body if isinstance(n, ast.FunctionDef)}, ref
