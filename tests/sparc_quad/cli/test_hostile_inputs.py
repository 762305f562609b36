"""A table of hostile command-line inputs, by class: each ends in a nonzero exit with a one-line error and
no traceback, before any work starts (run in this process: each case is refused while parsing or in the
command's first checks, so none may hang; the timeout marks a hang as a failure)."""

from __future__ import annotations

import errno
import sys
from pathlib import Path

import pytest

from sparc_quad.cli import main

BINARY = b"\x00\xff\xfe\x89PNG\r\n\x1a\n" * 8


def _cases(tmp: Path) -> list[tuple[str, list[str]]]:
    """(class, argv): every argv is nonsense that must be refused."""
    a_file = tmp / "a_file"
    no_dir = str(a_file / "out")  # a folder under a regular file: cannot be created
    spec = tmp / "spec.toml"
    cases: list[tuple[str, list[str]]] = []
    for cmd in (["bound"], ["bench", "static"], ["bench", "all"], ["demo"], ["gap", "synth"],
                ["gap", "run", "t.csv"], ["study", "run", str(spec)], ["bench-robot"],
                ["gap", "import", "panda", "--source", str(tmp)]):
        cases.append(("unwritable --out", [*cmd, "--out", no_dir]))
        cases.append(("empty --out", [*cmd, "--out", ""]))
        cases.append(("--out is a file", [*cmd, "--out", str(a_file)]))
    cases += [
        ("unwritable --summary", ["spine-node", "--summary", str(a_file / "s.json")]),
        ("unwritable --can-log", ["motors", "scan", "--can-log", str(a_file / "x.asc")]),
        ("unknown --can-log extension", ["motors", "scan", "--can-log", str(tmp / "x.nope")]),
        ("unknown --can-log extension", ["spine-node", "--motors", "can", "--can-log", str(tmp / "x")]),
        ("binary study spec", ["study", "run", str(tmp / "binary.toml"), "--out", str(tmp / "s")]),
        ("missing study spec", ["study", "run", str(tmp / "none.toml"), "--out", str(tmp / "s")]),
        ("scheduler address", ["study", "run", str(spec), "--out", str(tmp / "s"), "--scheduler", "garbage"]),
        ("scheduler address", ["study", "run", str(spec), "--out", str(tmp / "s"), "--scheduler",
                               "tcp://host:99999"]),
        ("study report of nothing", ["study", "report", str(tmp / "none")]),
        ("regex", ["spine-echo", "--channels", ""]),
        ("regex", ["spine-echo", "--channels", "("]),
        ("LCM URL", ["spine-node", "--lcm-url", ""]),
        ("LCM URL", ["spine-cmd", "--lcm-url", "nonsense"]),
        ("LCM URL", ["bound", "--lcm", "--lcm-url", "http://x"]),
        *[("an --lcm option without --lcm", ["bound", *opt]) for opt in
          (["--lcm-node-states"], ["--lcm-spin-us", "10"], ["--wait-node", "3"], ["--lcm-url", "memq://"])],
        ("the authors' twist, no estimate delay", ["bound", "--host", "spined-dog", "--engine", "mujoco",
                                                   "--gait", "sine", "--imu-delay", "0"]),
        ("the same on Solo12", ["bound", "--host", "solo12", "--engine", "mujoco", "--base-motion",
                                "authors-cvel", "--imu-delay", "0"]),
        ("motor ids", ["motors", "emulate", "--ids", "1,1"]),
        *[("motor ids", ["motors", "scan", "--ids", v])
          for v in ("0", "200", "-1", "nan", "", "1,,2", "0x80")],
        ("reply timeout", ["motors", "scan", "--timeout", "1e12"]),
        *[("lockstep poll", [*cmd, flag, v])
          for cmd, flag in ((["spine-node"], "--spin-us"), (["bench-robot"], "--spin-us"),
                            (["bound", "--lcm"], "--lcm-spin-us"))
          for v in ("nan", "-1", "1e12", "")],
        *[("wake latency", [*cmd, flag, v])
          for cmd, flag in ((["spine-node"], "--wake-latency-us"),
                            (["bound", "--lcm"], "--lcm-wake-latency-us"))
          for v in ("nan", "-1", "1e12", "", "0.5", "of")],
        ("watchdog deadline", ["motors", "watchdog", "--deadline", "1e12"]),
        ("host id", ["motors", "scan", "--host-id", "256"]),
        ("set-id without --new-id", ["motors", "set-id", "--ids", "1", "--yes", "--can-interface",
                                     "virtual"]),
        ("CAN bit rate", ["motors", "scan", "--can-bitrate", "1e12"]),
        ("CAN interface", ["motors", "scan", "--can-interface", "nosuch"]),
        ("CAN interface", ["motors", "status", "--can-interface", ""]),
        ("CAN interface", ["spine-node", "--motors", "can", "--can-interface", "nosuch", "--lcm-url",
                           "memq://"]),
        ("motor config", ["motors", "scan", "--motor-config", str(tmp / "none.toml")]),
        # durations that do not fit in memory, or never end
        ("duration", ["bound", "--duration", "1e12"]),
        ("duration", ["bench-robot", "--duration", "1e12"]),
        ("duration", ["spine-node", "--motors", "inprocess", "--experiment", "static", "--period", "500",
                      "--cycles", "10"]),
        ("duration", ["spine-node", "--duration", "1e300"]),
        ("duration", ["spine-cmd", "--duration", "inf"]),
        ("duration", ["motors", "emulate", "--duration", "1e12"]),
        ("duration", ["gap", "synth", "--period", "1e12", "--out", str(tmp / "g")]),
        ("duration", ["gap", "synth", "--period", "500", "--periods", "50", "--out", str(tmp / "g")]),
        # rates a 1 kHz loop cannot pace
        ("rate", ["spine-node", "--rate", "1e12"]),
        ("rate", ["spine-node", "--rate", "1"]),
        ("rate", ["spine-cmd", "--rate", "1e6", "--duration", "0.1"]),
        ("rate", ["spine-cmd", "--rate", "1e8"]),
        # physics and the hardware
        ("gain", ["spine-node", "--motors", "inprocess", "--kx", "1e12"]),
        ("gain", ["bench", "static", "--kx", "1e12"]),
        ("gain", ["bench", "dynamic", "--dx", "20,1e9"]),
        ("gain", ["bound", "--kth", "151"]),
        ("gain", ["spine-cmd", "--dth", "-1"]),
        ("torque", ["spine-cmd", "--tau-ff", "0", "13", "0"]),
        ("target pose", ["spine-cmd", "--lcm-url", "memq://", "--x-d", "5", "0", "0"]),
        ("soft start", ["spine-node", "--soft-start", "1e12"]),
        ("speed", ["bound", "--speed", "1e12"]),
        ("speed", ["bound", "--speed", "50", "--no-plots", "--out", str(tmp / "b")]),
        ("speed", ["bound", "--speed", "5", "--no-plots", "--out", str(tmp / "b")]),
        ("speed", ["bound", "--stride", "1.9", "--no-plots", "--out", str(tmp / "b")]),
        ("frequency", ["bound", "--frequency", "1e9"]),
        ("window", ["gap", "run", "t.csv", "--out", str(tmp / "g"), "--window", "1e12"]),
        ("count", ["bench", "dynamic", "--trials", "1e9"]),
        ("count", ["bench", "static", "--kx", ",".join(["500"] * 101)]),
        ("count", ["study", "report", str(tmp), "--bootstrap", "1e12"]),
        ("seed", ["bound", "--seed", str(2**64)]),
        ("seed", ["gap", "synth", "--seed", "-1", "--out", str(tmp / "g")]),
        ("effect spec", ["gap", "synth", "--effect", "nosuch", "--out", str(tmp / "g")]),
        ("effect spec", ["gap", "synth", "--effect", "coulomb_friction:joint=q9", "--out", str(tmp / "g")]),
        ("options of the other mode", ["gap", "synth", "--arm", "--effect", "coulomb_friction",
                                       "--out", str(tmp / "g")]),
        ("missing input file", ["gap", "run", str(tmp / "none.csv"), "--out", str(tmp / "g")]),
        ("missing input file", ["gap", "run", "t.csv", "--plant", str(tmp / "none.json"), "--out",
                                str(tmp / "g")]),
        ("missing import source", ["gap", "import", "tx40", "--source", str(tmp / "none"), "--out",
                                   str(tmp / "g")]),
        # nan / inf / wrong type in every numeric class
        *[("not a number", [*argv, v]) for v in ("nan", "inf", "-inf", "1e999", "abc", "0x10")
          for argv in (["bound", "--duration"], ["spine-node", "--rate"], ["motors", "scan", "--timeout"],
                       ["gap", "synth", "--out", str(tmp / "g"), "--period"], ["bench", "static", "--kx"])],
        # typos and unknown words
        ("typo", ["bound", "--kxx", "500"]),
        ("typo", ["bench", "static", "--kxx", "500"]),
        ("typo", ["gap", "synthh", "--out", str(tmp / "g")]),
        ("typo", ["nosuch"]),
        ("choice", ["bound", "--spine", "garbage"]),
        ("choice", ["motors", "garbage"]),
    ]
    return cases


def _prepare(tmp: Path) -> None:
    (tmp / "a_file").write_text("not a folder")
    (tmp / "binary.toml").write_bytes(BINARY)
    (tmp / "spec.toml").write_text('[study]\ngait = "bound"\n')


def _run(argv: list[str], capsys) -> tuple[int, str]:
    try:
        code = main(argv)
    except SystemExit as exc:
        code = exc.code
    return code, capsys.readouterr().err


CASES = _cases(Path("/TMP"))  # the table with a placeholder folder, for the test ids


@pytest.mark.timeout(120)
@pytest.mark.parametrize("index", range(len(CASES)),
                         ids=[f"{c}: {' '.join(a).replace('/TMP', '')}"[:90] for c, a in CASES])
def test_hostile_input_is_refused_in_one_line(index, tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    _prepare(tmp_path)
    what, argv = _cases(tmp_path)[index]
    code, err = _run(argv, capsys)
    assert code == 2, (what, code, err[-2000:])
    assert "Traceback" not in err and "internal error" not in err, err[-2000:]
    lines = [line for line in err.strip().splitlines() if ": note: " not in line]  # a renamed command's note
    assert "error" in lines[0], err  # the error first ...
    assert len(lines) <= 2, err  # ... then at most a short usage line
    assert not list(tmp_path.glob(".*.tmp-*")) and not list(tmp_path.glob("*.partial-*")), "outputs left"


def test_unwritable_folder_without_root_bypass(tmp_path, capsys):
    """A folder the file system refuses (here /proc, which even root cannot create files in)."""
    if not Path("/proc/self").exists():
        pytest.skip("no /proc")
    code, err = _run(["bound", "--out", "/proc/sparc-quad-out"], capsys)
    assert code == 2 and "cannot write" in err and "Traceback" not in err, err


@pytest.mark.parametrize(("number", "cause"), [(errno.ENODEV, "ip link"), (errno.EAFNOSUPPORT, "SocketCAN"),
                                               (errno.ENETDOWN, "is down")])
@pytest.mark.parametrize("argv", [["motors", "scan"], ["motors", "emulate", "--duration", "1"],
                                  ["motors", "watchdog", "--duration", "1"],
                                  ["spine-node", "--motors", "can", "--lcm-url", "memq://"]])
def test_bus_open_failure_is_one_line_naming_the_interface(argv, number, cause, monkeypatch, capsys):
    from spine_module.buses.cybergear import driver

    def no_such_bus(*args, **kwargs):
        raise OSError(number, "as the kernel says it")

    monkeypatch.setattr(driver, "open_bus", no_such_bus)
    code, err = _run([*argv, "--can-channel", "can7"], capsys)
    assert code == 2 and "Traceback" not in err, err
    line = err.strip().splitlines()[-1]
    assert "socketcan:can7" in line and cause in line, line
    assert len(err.strip().splitlines()) == 1, err


def test_emulate_names_its_extra_before_opening_the_bus(tmp_path):
    """The robot-side install (no pybullet): `motors emulate --plant bench` says which extra it needs, and
    no frame goes on the bus (the bus is opened only after the plant's modules import)."""
    import subprocess

    code = ("import sys; sys.modules['pybullet'] = None\n"
            "from spine_module.buses.cybergear import driver\n"
            "def refuse(*a, **k): raise SystemExit('bus opened')\n"
            "driver.open_bus = refuse\n"
            "from sparc_quad.cli import main\n"
            "sys.exit(main(['motors', 'emulate', '--plant', 'bench', '--duration', '1']))")
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120,
                         cwd=Path(__file__).resolve().parents[3])
    assert res.returncode == 2, res.stderr
    assert "pip install 'sparc-quad[sim]'" in res.stderr and "bus opened" not in res.stderr, res.stderr


@pytest.mark.parametrize(("argv", "says"), [
    (["--can-interface", "kvaser", "--can-channel", "0"], "kvaser"),
    (["--can-interface", "socketcand", "--can-channel", "can0"], "--can-option"),
    (["--can-interface", "nosuchbus", "--can-channel", "x"], "nosuchbus"),
])
def test_every_can_interface_opens_or_gives_one_line(argv, says, capsys):
    """python-can's interfaces that cannot be opened here (kvaser without canlib, socketcand without its host
    and port, an unknown name) end in exit 2 and one line naming the interface."""
    code, err = _run(["motors", "scan", *argv, "--timeout", "0.1"], capsys)
    lines = [line for line in err.strip().splitlines() if " WARNING: " not in line]  # python-can's own
    assert code == 2 and "Traceback" not in err and len(lines) == 1 and says in lines[0], err


def test_can_options_reach_python_can():
    from sparc_quad.cli.args import can_option

    assert can_option("host=10.0.0.2") == ("host", "10.0.0.2")
    assert can_option("port=29536") == ("port", 29536)
    assert can_option("fd=true") == ("fd", True)
    for bad in ("noequals", "1x=2", "bitrate=500000"):
        with pytest.raises(Exception, match=r"KEY=VALUE|own option"):
            can_option(bad)
