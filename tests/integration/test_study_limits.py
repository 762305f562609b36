"""A study never hangs and never loses a record: Ctrl-C of a large study exits 130 promptly with its tables
consistent, a scheduler that accepts and stays silent is named (exit 2), a full disk is one line (exit 1),
a study too long for its machine asks for --yes, one too large is refused before it is built."""

from __future__ import annotations

import errno
import os
import signal
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from sparc_quad.cli import main
from tests.paths import ROOT

LARGE = """[study]
name = "large"
seeds = 10
[scenario]
gait = "raibert"
duration = 0.3
[grid]
kx = [{kx}]
dx = [2, 4, 6, 8, 10]
"""


def _large_spec(tmp_path, cells: int = 400) -> str:
    path = tmp_path / "large.toml"
    path.write_text(LARGE.format(kx=", ".join(str(100 + i) for i in range(cells))))
    return str(path)


def test_ctrl_c_of_a_large_study_exits_130_with_whole_records(tmp_path):
    """20 000 trials on two workers: SIGINT once records are being written (the event: a record file)."""
    out = tmp_path / "out"
    argv = ["study", "run", _large_spec(tmp_path), "--out", str(out), "--workers", "2", "--no-progress",
            "--yes"]
    proc = subprocess.Popen([sys.executable, "-m", "sparc_quad", *argv], cwd=ROOT,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 300
    while not list((out / "trials").glob("*.json")):
        assert proc.poll() is None, proc.communicate()
        assert time.monotonic() < deadline, "no record written in 300 s"
        time.sleep(0.2)
    proc.send_signal(signal.SIGINT)
    try:
        _, err = proc.communicate(timeout=60)
    except subprocess.TimeoutExpired:
        proc.kill()
        raise AssertionError("the study did not end within 60 s of SIGINT") from None
    assert proc.returncode == 130, err[-2000:]
    assert "Traceback" not in err
    rows = (out / "trials.csv").read_text().strip().splitlines()
    records = list((out / "trials").glob("*.json"))
    assert len(rows) - 1 == len(records) >= 1  # the table lists exactly the whole records


@pytest.mark.timeout(180)
def test_a_silent_scheduler_is_named(tmp_path, capsys):
    """A TCP listener that accepts and never answers: exit 2 naming it, within the timeout."""
    pytest.importorskip("distributed")
    server = socket.socket()
    server.bind(("127.0.0.1", 0))
    server.listen(8)
    held = []
    stop = threading.Event()

    def accept() -> None:
        server.settimeout(0.2)
        while not stop.is_set():
            try:
                held.append(server.accept()[0])  # keep it open, say nothing
            except TimeoutError:
                continue

    thread = threading.Thread(target=accept, daemon=True)
    thread.start()
    spec = tmp_path / "s.toml"
    spec.write_text('[scenario]\ngait = "raibert"\nduration = 0.3\n')
    try:
        code = main(["study", "run", str(spec), "--out", str(tmp_path / "o"), "--no-progress", "--scheduler",
                     f"tcp://127.0.0.1:{server.getsockname()[1]}", "--scheduler-timeout", "2"])
    finally:
        stop.set()
        thread.join()
        for conn in held:
            conn.close()
        server.close()
    err = capsys.readouterr().err
    assert code == 2 and "127.0.0.1" in err and "Traceback" not in err, err  # a hang: pytest-timeout


def test_a_full_disk_is_one_line_and_the_records_stay_whole(tmp_path, capsys, monkeypatch):
    from sparc_quad.study import records, runner

    spec = tmp_path / "s.toml"
    spec.write_text('[study]\nseeds = 3\n[scenario]\ngait = "raibert"\nduration = 0.3\n')
    written = []

    def write_once(trials_dir, rec):
        if written:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        written.append(records.write_record(trials_dir, rec))
        return written[-1]

    monkeypatch.setattr(runner, "write_record", write_once)
    monkeypatch.setattr(runner, "write_csv", lambda *a, **k: (_ for _ in ()).throw(
        OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))))
    code = main(["study", "run", str(spec), "--out", str(tmp_path / "o"), "--workers", "1", "--no-progress"])
    err = capsys.readouterr().err
    assert code == 1, err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and "No space left on device" in lines[0] and "Traceback" not in err, err
    assert len(list((tmp_path / "o" / "trials").glob("*.json"))) == 1  # the record written before is whole


def test_a_long_study_asks_for_yes_and_a_huge_one_is_refused_at_once(tmp_path, capsys, monkeypatch):
    long = Path(_large_spec(tmp_path, cells=1000))
    long.write_text(long.read_text().replace("duration = 0.3", "duration = 10.0"))
    code = main(["study", "run", str(long), "--out", str(tmp_path / "o"), "--workers", "1"])
    # 1000 x 5 x 10 = 50 000 trials of 10 s: within the size limit, but days: asks for --yes
    err = capsys.readouterr().err
    assert code == 2 and "--yes" in err and "trials" in err, err
    assert not (tmp_path / "o").exists()  # nothing was created
    huge = tmp_path / "huge.toml"
    huge.write_text("[study]\nseeds = 1000000000\n")
    assert main(["study", "run", str(huge), "--out", str(tmp_path / "h")]) == 2
    assert "study.seeds" in capsys.readouterr().err and not (tmp_path / "h").exists()
    big = tmp_path / "big.toml"
    kx = ", ".join(str(i) for i in range(1, 1001))
    big.write_text(f"[study]\nseeds = 10000\n[grid]\nkx = [{kx}]\n")
    from sparc_quad.study import spec as spec_module

    built = []
    monkeypatch.setattr(spec_module, "expand", lambda s: built.append(s) or [])  # sized, never built
    assert main(["study", "run", str(big), "--out", str(tmp_path / "b")]) == 2
    assert "more than 100000" in capsys.readouterr().err and built == [] and not (tmp_path / "b").exists()
