"""A bug is never reported as bad input: exit 1, "internal error", the traceback in a log file beside the
output folder (or on stderr with -v), the partial outputs kept. Ctrl-C while the CLI imports: exit 130,
no traceback."""

from __future__ import annotations

import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from sparc_quad.cli import main

ROOT = Path(__file__).resolve().parents[3]


def _break_static(monkeypatch) -> None:
    """bench static's writer writes one file, then fails as a bug would."""
    from sparc_quad.experiments import static

    def write_half(rows, raw, cfg, out):
        (Path(out) / "static.json").write_text("{half")
        raise ZeroDivisionError("a bug in the writer")

    monkeypatch.setattr(static, "run_static", lambda cfg, progress=None: ([], {}))
    monkeypatch.setattr(static, "write_static", write_half)


def test_internal_error_is_exit_1_with_log_and_partial_outputs(tmp_path, monkeypatch, capsys):
    _break_static(monkeypatch)
    out = tmp_path / "res"
    assert main(["bench", "static", "--out", str(out)]) == 1
    err = capsys.readouterr().err.strip().splitlines()[-1]  # after the progress bar
    assert "Traceback" not in capsys.readouterr().err
    assert err.startswith("sparc-quad bench static: internal error") and "ZeroDivisionError" in err, err
    logs = list(tmp_path.glob("sparc-quad-bench-static-internal-error-*.log"))
    assert len(logs) == 1 and str(logs[0]) in err
    assert "Traceback" in logs[0].read_text() and "write_half" in logs[0].read_text()
    kept = list(tmp_path.glob("res.partial-*"))
    assert len(kept) == 1 and str(kept[0]) in err
    assert (kept[0] / "static.json").read_text() == "{half"
    assert not out.exists() or not any(out.iterdir())  # --out itself has nothing of the failed run


def test_internal_error_traceback_on_stderr_with_verbose(tmp_path, monkeypatch, capsys):
    _break_static(monkeypatch)
    assert main(["-v", "bench", "static", "--out", str(tmp_path / "res")]) == 1
    err = capsys.readouterr().err
    assert "Traceback" in err and "write_half" in err and "internal error" in err
    assert not list(tmp_path.glob("*.log"))


def test_library_bad_input_is_exit_2_and_leaves_nothing(tmp_path, capsys):
    bad = tmp_path / "t.csv"
    bad.write_text("not,a,trial\n1,2\n")
    assert main(["gap", "run", str(bad), "--out", str(tmp_path / "g"), "--no-plots"]) == 2
    err = capsys.readouterr().err
    assert "sparc-quad gap run: error:" in err and "internal error" not in err, err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["t.csv"]


def _sigint_default() -> None:
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def _mapped(pid: int, name: str) -> bool:
    try:
        return name in Path(f"/proc/{pid}/maps").read_text()
    except OSError:
        return False


@pytest.mark.skipif(not Path("/proc/self/maps").exists(), reason="needs /proc/<pid>/maps")
@pytest.mark.parametrize("library", ["_multiarray_umath", "_lcm"])
def test_ctrl_c_while_importing_is_130_without_traceback(library):
    """SIGINT as soon as the child has loaded `library`: numpy's core (the CLI's own imports are under way)
    and LCM's (the command has just started)."""
    proc = subprocess.Popen([sys.executable, "-m", "sparc_quad", "spine-echo", "--lcm-url", "memq://",
                             "--timeout", "60"], cwd=ROOT, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                            text=True, preexec_fn=_sigint_default)
    try:
        while not _mapped(proc.pid, library):
            assert proc.poll() is None, proc.stderr.read()
            time.sleep(0.001)
        proc.send_signal(signal.SIGINT)
        _, err = proc.communicate(timeout=120)
    finally:
        proc.kill()
    assert proc.returncode == 130 and "Traceback" not in err, (proc.returncode, err)
    assert err.strip().endswith("interrupted"), err


def test_ctrl_c_while_building_the_parser_in_process(monkeypatch, capsys):
    import sparc_quad.cli as cli

    def interrupted(name):
        raise KeyboardInterrupt

    monkeypatch.setattr(cli.importlib, "import_module", interrupted)
    assert cli.main(["bound", "--help"]) == 130
    assert capsys.readouterr().err.strip() == "sparc-quad: interrupted"


def test_a_full_disk_is_one_line_exit_1_and_nothing_kept(tmp_path, monkeypatch, capsys):
    """A full disk behind whatever the writer raised (here a ValueError raised while handling ENOSPC) is
    neither bad input nor a bug: exit 1, one line naming it and --out, the half-written outputs removed."""
    import errno
    import os

    from sparc_quad.experiments import static

    def write_full(rows, raw, cfg, out):
        (Path(out) / "static.json").write_text("{half")
        try:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        except OSError:
            raise ValueError("the writer gave up") from None  # the disk-full error stays its __context__

    monkeypatch.setattr(static, "run_static", lambda cfg, progress=None: ([], {}))
    monkeypatch.setattr(static, "write_static", write_full)
    out = tmp_path / "o"
    assert main(["bench", "static", "--out", str(out)]) == 1
    err = capsys.readouterr().err.strip()
    line = err.splitlines()[-1]  # after the progress bar
    assert line.startswith("sparc-quad bench static: error: No space left on device") and str(out) in line
    assert "internal error" not in err and "Traceback" not in err and err.count("error") == 1, err
    assert sorted(p.name for p in tmp_path.iterdir()) == []  # no partial folder, no log, no --out


def test_unknown_options_are_named_before_values_are_read():
    from sparc_quad.cli.parser import Parser

    p = Parser(prog="x").add_subparsers(dest="c").add_parser("run")
    p.add_argument("spec", type=int)
    p.add_argument("--workers", type=int)
    p.add_argument("-v", action="count")
    assert p.unknown_options(["--workrs", "2", "-5", "--work", "--workers=3", "-vv", "--", "--x"]) == \
        ["--workrs"]
