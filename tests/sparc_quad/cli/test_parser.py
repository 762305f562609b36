"""One help style for every command, its own usage on a typo, negative numbers as values, --version,
and `spine-cmd` paced to its rate for its duration."""

from __future__ import annotations

import argparse
import json
import re
import tomllib
from pathlib import Path

import pytest

from sparc_quad.cli import build_parser, main
from sparc_quad.cli.parser import Formatter
from sparc_quad.cli.spine_cmd import pace

ROOT = Path(__file__).resolve().parents[3]


def _parsers(parser: argparse.ArgumentParser):
    yield parser
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for sub in dict.fromkeys(action.choices.values()):
                yield from _parsers(sub)


PARSERS = list(_parsers(build_parser()))


@pytest.mark.parametrize("parser", PARSERS, ids=[p.prog for p in PARSERS])
def test_help_in_one_style(parser):
    text = parser.format_help()
    assert "np." not in text and "numpy" not in text, text
    assert not re.search(r"\(default [^:]", text.replace("\n", " ")), text  # "(default: X)" only
    fmt = Formatter(parser.prog)
    for action in parser._actions:
        if isinstance(action, (argparse._HelpAction, argparse._VersionAction, argparse._SubParsersAction)):
            continue
        name = "/".join(action.option_strings) or action.dest
        assert action.help, f"{parser.prog} {name} has no help"
        shown = fmt._expand_help(action)
        empty = isinstance(action.default, list | tuple) and not action.default  # repeatable, given 0 times
        if action.option_strings and action.default not in (None, False, argparse.SUPPRESS) and not empty:
            assert "(default: " in shown, f"{parser.prog} {name}: {shown!r}"
        assert "None" not in shown and "<class" not in shown and " object at " not in shown, shown


def test_defaults_shown_as_typed(capsys):
    with pytest.raises(SystemExit):
        main(["spine-cmd", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "(default: 0.273 0.0 0.0)" in text and "(default: 500.0)" in text


@pytest.mark.parametrize(("argv", "usage"), [
    (["bound", "--kxx", "500"], "usage: sparc-quad bound"),
    (["bench", "static", "--kxx", "500"], "usage: sparc-quad bench static"),
    (["gap", "synth", "--out", "o", "--nope"], "usage: sparc-quad gap synth"),
    (["motors", "scan", "--nope"], "usage: sparc-quad motors"),
])
def test_typo_prints_the_subcommands_usage(argv, usage, capsys):
    with pytest.raises(SystemExit) as exc:
        main(argv)
    err = capsys.readouterr().err
    first, *rest = err.strip().splitlines()
    assert exc.value.code == 2 and " error: " in first, err
    assert first.startswith(usage.removeprefix("usage: ")), err
    assert "unrecognized arguments" in first and len(rest) == 1 and rest[0].startswith(usage), err


def test_a_near_miss_is_named():
    import subprocess
    import sys

    r = subprocess.run([sys.executable, "-m", "sparc_quad", "bound", "--kxx", "500"], capture_output=True,
                       text=True, timeout=120)
    assert r.returncode == 2 and "(did you mean --kx?)" in r.stderr.splitlines()[0], r.stderr


def test_negative_numbers_are_values(capsys):
    with pytest.raises(SystemExit):
        main(["bench", "static", "--kx", "-5,300"])
    err = capsys.readouterr().err
    assert "argument --kx" in err and "must be in" in err, err  # reached the range check
    args = build_parser().parse_args(["spine-cmd", "--x-d", "0.27", "-0.01", "-.02", "--tau-ff", "-1", "0",
                                      "-2.5"])
    assert args.x_d == [0.27, -0.01, -0.02] and args.tau_ff == [-1.0, 0.0, -2.5]


def test_version(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["--version"])
    version = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["version"]
    assert exc.value.code == 0 and capsys.readouterr().out.strip() == f"sparc-quad {version}"


class FakeTime:
    """A clock that `sleep` advances, plus `cost` seconds of work per clock read."""

    def __init__(self, cost: float = 0.0) -> None:
        self.t, self.cost = 100.0, cost

    def clock(self) -> float:
        self.t += self.cost
        return self.t

    def sleep(self, s: float) -> None:
        assert s >= 0
        self.t += s


def test_pace_sends_rate_times_duration_on_schedule():
    ft, stamps = FakeTime(), []
    n = pace(50.0, 2.0, lambda i: stamps.append(ft.t), clock=ft.clock, sleep=ft.sleep)
    assert n == 100 == len(stamps)
    assert stamps == pytest.approx([100.0 + i / 50.0 for i in range(100)])


def test_pace_ends_on_time_when_the_loop_is_slower_than_the_rate():
    """Each send costs 3 ms at 1 kHz: late slots are skipped, and nothing is sent after the duration."""
    ft, stamps = FakeTime(), []

    def send(i):
        stamps.append(ft.t)
        ft.t += 0.003

    n = pace(1000.0, 0.1, send, clock=ft.clock, sleep=ft.sleep)
    assert 25 <= n <= 34 and all(t < 100.1 for t in stamps), (n, stamps[-3:])


def test_pace_once_and_stop():
    ft = FakeTime()
    assert pace(50.0, 0.0, lambda i: None, clock=ft.clock, sleep=ft.sleep) == 1
    assert pace(50.0, 10.0, lambda i: None, stop=lambda: True, clock=ft.clock, sleep=ft.sleep) == 1


def test_spine_cmd_sends_at_most_rate_times_duration(capsys):
    assert main(["spine-cmd", "--lcm-url", "memq://", "--rate", "1000", "--duration", "0.05"]) == 0
    sent = json.loads(capsys.readouterr().out.strip().splitlines()[-1])["sent"]
    assert 1 <= sent <= 50


def test_earlier_gap_spellings_still_work(capsys):
    from sparc_quad.cli.gap import legacy_argv

    assert legacy_argv(["gap", "t.csv", "--out", "o"]) == ["gap", "run", "t.csv", "--out", "o"]
    assert legacy_argv(["-v", "gap", "synth-arm", "--out", "o"]) == ["-v", "gap", "synth", "--arm", "--out",
                                                                     "o"]
    assert "is now `gap run t.csv ...`" in capsys.readouterr().err
    for same in (["gap", "run", "t.csv"], ["gap", "synth"], ["gap", "--help"], ["bound", "gap"]):
        assert legacy_argv(same) == same


def test_bound_warns_when_the_gait_misses_its_speed():
    """A gait far below its commanded speed with a good window gets the warning; the figures are those of a
    6 s solo12 bound commanded to 3 m/s (notebook/2026-12-07-test-docstring-figures.md)."""
    from sparc_quad.cli.bound import speed_warning

    steady = {"window_ok": True, "fell": False, "speed_m_s": 1.908}
    assert "below 0.75 x the target 3 m/s" in speed_warning(steady, 3.0)
    assert speed_warning(steady, 2.0) is None
    assert speed_warning({**steady, "window_ok": False}, 3.0) is None  # that has its own warning
    assert speed_warning({**steady, "fell": True}, 3.0) is None
    assert speed_warning(steady, None) is None  # the sine gait has no target speed
