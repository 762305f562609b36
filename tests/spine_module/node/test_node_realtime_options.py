"""Real-time options of the node: tick-period histogram, absolute schedule, process set-up."""

from __future__ import annotations

import json
import os
import struct
import subprocess
import sys
from pathlib import Path

import pytest

from spine_module.node import clocks, realtime
from spine_module.node.clocks import PeriodHistogram, RealTimeClock
from tests.paths import ROOT


def test_histogram_percentiles() -> None:
    h = PeriodHistogram(nominal_s=1e-3)
    for _ in range(990):
        h.add(1.0e-3)
    for _ in range(9):
        h.add(1.8e-3)
    h.add(0.5)  # beyond the histogram's range: overflow bin, max kept
    s = h.summary()
    assert s["ticks_measured"] == 1000
    assert 1000.0 <= s["p50_us"] <= 1001.0
    assert 1000.0 <= s["p99_us"] <= 1001.0  # 990 of 1000 at 1 ms
    assert 1800.0 <= s["p99_9_us"] <= 1801.0
    assert s["max_us"] == pytest.approx(5e5)
    assert s["over_1_5x_nominal"] == 10
    assert PeriodHistogram(1e-3).summary()["ticks_measured"] == 0


class FakeTime:
    """monotonic() and sleep() on a simulated clock: sleep advances it, `stall` injects a late wake-up."""

    def __init__(self) -> None:
        self.t = 100.0
        self.stall = 0.0

    def monotonic(self) -> float:
        return self.t

    def sleep(self, s: float) -> None:
        self.t += s + self.stall
        self.stall = 0.0


def test_clock_keeps_an_absolute_schedule(monkeypatch) -> None:
    fake = FakeTime()
    monkeypatch.setattr(clocks.time, "monotonic", fake.monotonic)
    monkeypatch.setattr(clocks.time, "sleep", fake.sleep)
    clock = RealTimeClock(1000.0, spin_s=0.0)
    t = [clock.wait() for _ in range(3)]
    assert t == pytest.approx([0.001, 0.002, 0.003])
    fake.stall = 0.0025  # this tick wakes 2.5 periods late: an overrun, and t_next is NOT reset ...
    assert clock.wait() == pytest.approx(0.0065)
    assert clock.overruns == 1 and clock.rephases == 0
    # ... so the following ticks are due at once (lost time recovered) and land back on the 1 ms grid
    t = [clock.wait() for _ in range(4)]
    assert t == pytest.approx([0.0065, 0.0065, 0.007, 0.008])
    assert clock.overruns == 2  # the 5 ms tick also began more than a period late; the 6 ms one did not
    fake.stall = 0.010  # more than 5 periods behind: re-phase instead of a burst of 10 ticks
    clock.wait()
    assert clock.rephases == 1 and clock.overruns == 3
    t0 = clock.wait()
    assert clock.wait() - t0 == pytest.approx(0.001)


def test_cpu_not_available_is_named() -> None:
    bad = max(os.sched_getaffinity(0)) + 1
    with pytest.raises(realtime.RtSetupError, match=f"--cpu {bad}: not a CPU"):
        realtime.apply(realtime.RtOptions(cpu=bad))


def test_cpu_pinning_applies_and_reports() -> None:
    before = os.sched_getaffinity(0)
    cpu = min(before)
    try:
        # (memory locking is tried in a subprocess below: mlockall would pin this test process's memory)
        lines = realtime.apply(realtime.RtOptions(cpu=cpu, freeze_gc=True))
        assert os.sched_getaffinity(0) == {cpu}
    finally:
        os.sched_setaffinity(0, before)
    assert lines[0] == f"pinned to CPU {cpu}"
    assert "frozen" in lines[1]


def test_rt_priority_not_permitted_says_how(monkeypatch) -> None:
    def refuse(*_a):
        raise PermissionError(1, "Operation not permitted")

    monkeypatch.setattr(realtime.os, "sched_setscheduler", refuse)
    with pytest.raises(realtime.RtSetupError, match=r"not permitted.*rtprio"):
        realtime.apply(realtime.RtOptions(rt_priority=50))


@pytest.mark.parametrize("argv, message", [
    (["--cpu", "4096"], "--cpu 4096: not a CPU"),
    (["--rt-priority", "0"], "--rt-priority: must be in [1, 99]"),
    (["--cpu", "-1"], "--cpu: must be in [0, inf]"),
])
def test_cli_rejects_bad_rt_options(argv: list[str], message: str) -> None:
    r = subprocess.run([sys.executable, "-m", "sparc_quad", "spine-node", "--lcm-url", "memq://",
                        "--duration", "0.01", *argv], capture_output=True, text=True, cwd=ROOT, timeout=120)
    assert r.returncode == 2
    assert message in r.stderr
    assert "Traceback" not in r.stderr


def test_node_summary_reports_the_period_histogram(tmp_path: Path) -> None:
    out = tmp_path / "node.json"
    r = subprocess.run([sys.executable, "-m", "sparc_quad", "spine-node", "--lcm-url", "memq://",
                        "--no-heartbeat", "--duration", "0.2", "--lock-memory", "--summary", str(out)],
                       capture_output=True, text=True, cwd=ROOT, timeout=120)
    assert r.returncode == 0, r.stderr
    s = json.loads(out.read_text())
    # in the order applied; no wake-latency hold by default with the simulated (lcm) backend (issue 31:
    # only --motors can holds it unless asked, tests/integration/test_node_cli_defaults.py)
    lock, frozen = s["realtime"]
    assert lock == "memory locked (mlockall)" or lock.startswith("memory not locked: ")
    assert "frozen" in frozen
    p = s["period"]
    assert p["ticks_measured"] == s["ticks"] - 1
    assert 0 < p["p50_us"] <= p["p99_us"] <= p["p99_9_us"] <= p["max_us"]
    assert p["nominal_us"] == 1000.0
    assert s["overruns"] >= 0


def test_wake_latency_request_is_written_and_held_until_released(tmp_path) -> None:
    qos = tmp_path / "cpu_dma_latency"
    qos.write_bytes(b"")
    realtime.release_wake_latency()  # whatever an earlier test's command left (it should leave nothing)
    line = realtime.hold_wake_latency(7, path=str(qos))
    try:
        assert line.startswith("CPU wake latency held at <= 7 us")
        assert qos.read_bytes() == struct.pack("=i", 7)  # the kernel's format: one native 32-bit integer
        assert len(realtime._wake_latency_fds) == 1  # open: closing the file would drop the request
    finally:
        realtime.release_wake_latency()
    assert realtime._wake_latency_fds == []


def test_a_command_run_in_process_leaves_no_wake_latency_request(monkeypatch, tmp_path) -> None:
    from sparc_quad.cli import main

    qos = tmp_path / "cpu_dma_latency"
    qos.write_bytes(b"")
    real = realtime.hold_wake_latency
    monkeypatch.setattr(realtime, "hold_wake_latency", lambda us: real(us, path=str(qos)))
    realtime.release_wake_latency()
    # no node answers on memq: the command ends with its "start spine-node first" error, after the request
    rc = main(["bound", "--lcm", "--lcm-url", "memq://", "--wait-node", "0.05", "--duration", "0.1",
               "--lcm-wake-latency-us", "0", "--no-plots", "--out", str(tmp_path / "b")])
    assert rc == 2 and qos.read_bytes() == struct.pack("=i", 0)  # it was made ...
    assert realtime._wake_latency_fds == []  # ... and ended with the command
    qos.write_bytes(b"")  # a simulation asks for nothing unless told (issue 31: off for bound --lcm)
    rc = main(["bound", "--lcm", "--lcm-url", "memq://", "--wait-node", "0.05", "--duration", "0.1",
               "--no-plots", "--out", str(tmp_path / "c")])
    assert rc == 2 and qos.read_bytes() == b""


@pytest.mark.parametrize("make, why", [
    (lambda d: d / "absent", "does not exist"),
    (lambda d: d, "Is a directory"),
])
def test_wake_latency_not_available_is_reported_not_raised(tmp_path, make, why) -> None:
    realtime.release_wake_latency()
    line = realtime.hold_wake_latency(0, path=str(make(tmp_path)))
    assert line.startswith("CPU wake latency not requested") and why in line
    assert realtime._wake_latency_fds == []


def test_wake_latency_not_permitted_says_root(monkeypatch) -> None:
    def refuse(*_a):
        raise PermissionError(13, "Permission denied")

    monkeypatch.setattr(realtime.os, "open", refuse)
    assert "needs root" in realtime.hold_wake_latency(0)


def test_wake_latency_out_of_range_is_a_caller_error() -> None:
    with pytest.raises(ValueError, match=r"0\.\.2147483647 us"):
        realtime.hold_wake_latency(-1)


def test_rt_options_apply_the_wake_latency(monkeypatch) -> None:
    asked = []
    monkeypatch.setattr(realtime, "hold_wake_latency", lambda us: asked.append(us) or f"held {us}")
    assert realtime.apply(realtime.RtOptions(wake_latency_us=0)) == ["held 0"]
    assert realtime.apply(realtime.RtOptions()) == [] and asked == [0]


@pytest.mark.parametrize("text, value", [("0", 0), ("50", 50), ("off", None), (" OFF ", None)])
def test_wake_latency_option_parses_microseconds_or_off(text, value) -> None:
    from sparc_quad.cli.args import wake_latency_us

    assert wake_latency_us(text) == value
