"""Ctrl-C during `bound`, `bench`, `gap synth` and `gap run` ends cleanly (exit 130, one line, no traceback),
and --out holds the whole previous result: the new one is written to a temporary sibling that replaces the
folder only when complete."""

from __future__ import annotations

import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from sparc_quad.cli.output import atomic_dir
from tests.paths import ROOT


def _previous_result(out: Path) -> None:
    out.mkdir(parents=True)
    (out / "previous.json").write_text('{"run": "previous"}\n')


def _wait_for(pred, proc: subprocess.Popen, what: str, timeout_s: float = 300.0) -> None:
    deadline = time.monotonic() + timeout_s
    while not pred():
        if proc.poll() is not None:
            raise AssertionError(f"exited ({proc.returncode}) before {what}: {proc.stderr.read()[-2000:]}")
        if time.monotonic() > deadline:
            proc.kill()
            raise AssertionError(f"no {what} within {timeout_s} s")
        time.sleep(0.05)


def _sigint_default() -> None:
    """In the child before exec: SIGINT as a terminal gives it. A shell without job control starts its
    background jobs (and so this test run, e.g. `make test &` in a script) with SIGINT ignored, which the
    child would inherit: Python then installs no KeyboardInterrupt handler and Ctrl-C does nothing."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def _interrupt(argv: list[str], out: Path) -> tuple[int, str]:
    """Start the command, SIGINT it once it has begun its temporary output folder, return (rc, stderr)."""
    proc = subprocess.Popen([sys.executable, "-m", "sparc_quad", *argv, "--out", str(out)], cwd=ROOT,
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
                            preexec_fn=_sigint_default)
    _wait_for(lambda: any(out.parent.glob(f".{out.name}.tmp-*")), proc, "temporary output folder")
    proc.send_signal(signal.SIGINT)
    try:
        _, err = proc.communicate(timeout=300)
    except subprocess.TimeoutExpired:
        proc.kill()
        raise
    return proc.returncode, err


def _check(rc: int, err: str, out: Path, command: str) -> None:
    assert rc == 130, err[-3000:]
    assert "Traceback" not in err, err[-3000:]
    assert err.strip().splitlines()[-1] == f"sparc-quad {command}: interrupted", err[-3000:]
    assert sorted(p.name for p in out.iterdir()) == ["previous.json"]  # the old result, whole
    assert (out / "previous.json").read_text() == '{"run": "previous"}\n'
    assert not list(out.parent.glob(f".{out.name}.*")), "temporary folder left behind"


@pytest.mark.parametrize(("argv", "command"), [
    (["bound", "--duration", "60"], "bound"),
    (["bench", "static", "--kx", ",".join(["500"] * 20)], "bench static"),
    (["gap", "synth", "--effect", "coulomb_friction:joint=q3,tau_c_nm=0.15", "--trials-n", "200",
      "--periods", "20"], "gap synth"),
])
def test_ctrl_c_exits_130_and_keeps_the_previous_result(tmp_path, argv, command):
    out = tmp_path / "out"
    _previous_result(out)
    rc, err = _interrupt(argv, out)
    _check(rc, err, out, command)


def test_ctrl_c_during_gap_workflow(tmp_path):
    trials = tmp_path / "trials"
    subprocess.run([sys.executable, "-m", "sparc_quad", "gap", "synth", "--effect",
                    "coulomb_friction:joint=q3,tau_c_nm=0.15", "--trials-n", "2", "--periods", "4",
                    "--out", str(trials)], cwd=ROOT, check=True, capture_output=True, timeout=600)
    out = tmp_path / "gap"
    _previous_result(out)
    rc, err = _interrupt(["gap", "run", *map(str, sorted(trials.glob("trial_*.csv")))], out)
    _check(rc, err, out, "gap run")


def test_atomic_dir_is_whole_or_untouched(tmp_path):
    out = tmp_path / "out"
    _previous_result(out)
    (out / "other.log").write_text("another program's")
    with pytest.raises(KeyboardInterrupt), atomic_dir(out) as tmp:
        (tmp / "previous.json").write_text("half")
        raise KeyboardInterrupt
    assert sorted(p.name for p in out.iterdir()) == ["other.log", "previous.json"]
    assert (out / "previous.json").read_text() == '{"run": "previous"}\n'
    with pytest.raises(RuntimeError) as failed, atomic_dir(out) as tmp:  # a bug: kept for diagnosis
        (tmp / "previous.json").write_text("half")
        raise RuntimeError("half-way")
    assert sorted(p.name for p in out.iterdir()) == ["other.log", "previous.json"]
    assert (out / "previous.json").read_text() == '{"run": "previous"}\n'
    kept = failed.value.partial_outputs
    assert kept.parent == tmp_path and kept.name.startswith("out.partial-")
    assert (kept / "previous.json").read_text() == "half"
    shutil.rmtree(kept)
    with open(out / "other.log", "a") as still_writing, atomic_dir(out) as tmp:
        (tmp / "previous.json").write_text("new")
        (tmp / "sub").mkdir()
        (tmp / "sub" / "plot.png").write_text("png")
        still_writing.write(" log")  # a process writing into --out meanwhile loses nothing
    assert sorted(str(p.relative_to(out)) for p in out.rglob("*")) == ["other.log", "previous.json", "sub",
                                                                        "sub/plot.png"]
    assert (out / "previous.json").read_text() == "new"
    assert (out / "other.log").read_text() == "another program's log"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]  # no temporary folder left


def _interrupting_mkdir(how: str):
    """A stand-in for the folder's creation that is interrupted right after its mkdir: by a SIGINT to
    this process (held by the mask until the clean-up owns the folder), or by a KeyboardInterrupt raised
    in place (what a signal delivered to another thread of the process raises here, mask or not)."""
    import os

    def make(path):
        os.mkdir(path, 0o700)
        if how == "signal":
            os.kill(os.getpid(), signal.SIGINT)
        else:
            raise KeyboardInterrupt

    return make


@pytest.mark.parametrize("how", ["signal", "raised"])
def test_an_interrupt_inside_the_folder_creation_leaves_no_folder_and_no_blocked_signal(tmp_path, monkeypatch,
                                                                                         how):
    from sparc_quad.cli import output

    monkeypatch.setattr(output, "_make_tmp", _interrupting_mkdir(how))
    old = signal.signal(signal.SIGINT, signal.default_int_handler)  # Python's Ctrl-C, whatever runs us
    try:
        with pytest.raises(KeyboardInterrupt):
            with atomic_dir(tmp_path / "out"):
                raise AssertionError("the interrupt must be raised before the body runs")
        mask = signal.pthread_sigmask(signal.SIG_BLOCK, ())
    finally:
        signal.signal(signal.SIGINT, old)
    assert not list(tmp_path.glob(".out.*")), "temporary folder left behind"
    assert signal.SIGINT not in mask and signal.SIGTERM not in mask, f"signals left blocked: {mask}"


def test_a_name_taken_by_another_folder_is_skipped_and_left_alone(tmp_path, monkeypatch):
    from sparc_quad.cli import output

    theirs = tmp_path / ".out.tmp-aaaa"
    theirs.mkdir()
    (theirs / "keep.txt").write_text("not ours")
    names = iter(["aaaa", "bbbb"])
    monkeypatch.setattr(output.secrets, "token_hex", lambda n: next(names))
    with atomic_dir(tmp_path / "out") as tmp:
        assert tmp.name == ".out.tmp-bbbb"
        (tmp / "r.json").write_text("{}")
    assert (theirs / "keep.txt").read_text() == "not ours"
    assert (tmp_path / "out" / "r.json").exists() and not (tmp_path / ".out.tmp-bbbb").exists()
