"""Run a shell script inside a private network namespace with multicast on loopback, for LCM over UDP
multicast between processes without touching the host network."""

from __future__ import annotations

import functools
import shutil
import subprocess
import sys
from pathlib import Path

SETUP = "ip link set lo up multicast on && ip route add 224.0.0.0/4 dev lo\n"


@functools.cache
def unshare_prefix() -> tuple[str, ...] | None:
    """`unshare -rn` (user namespace) or, as root, `unshare -n`; None when neither works here."""
    if shutil.which("unshare") is None or shutil.which("ip") is None:
        return None
    for prefix in (("unshare", "-rn"), ("unshare", "-n")):
        try:
            r = subprocess.run([*prefix, "sh", "-c", SETUP], capture_output=True, timeout=20)
        except (OSError, subprocess.TimeoutExpired):
            continue
        if r.returncode == 0:
            return prefix
    return None


# the recorded session of tests/conftest.py::lcm_run: static push-pull at K N/m over one PERIOD s
K, PERIOD = 500.0, 2.0


def lcm_tool(name: str) -> str:
    """An LCM tool shipped with the lcm wheel. The wheel's console script is a Python wrapper that runs
    the real binary as a child (a signal to the wrapper does not reach it), so prefer the binary."""
    import lcm

    binary = Path(lcm.__file__).resolve().parent.parent / "bin" / name
    if binary.exists():
        return str(binary)
    here = Path(sys.executable).parent / name
    return str(here) if here.exists() else (shutil.which(name) or name)


# the namespace's own UDP counters (/proc/net/snmp is per network namespace): `cat` them into a file at
# the end of a script; RcvbufErrors counts datagrams the kernel dropped at a full socket receive buffer
UDP_COUNTERS = "cat /proc/net/snmp > {out}/udp_snmp.txt\n"


def udp_rcvbuf_errors(path: Path) -> int:
    """Datagrams the kernel dropped in the namespace because a receiver's socket buffer was full: the loss
    a loaded host may cause with any receive buffer (a machine with net.core.rmem_max at its 208 KiB
    default gives LCM's 2 MB request only that much), as opposed to a datagram never sent or never read."""
    lines = [ln.split() for ln in path.read_text().splitlines() if ln.startswith("Udp:")]
    header, values = lines[0], lines[1]
    return int(values[header.index("RcvbufErrors")])


# lcm-logger's own LCM queue (30 messages per subscription by LCM's default, no counter) drops when its
# dispatching thread is descheduled: at load, 3 whole ticks were missing here with no kernel drop; CI once
# lacked 45 of 2000 states (before the counters were kept, so its cause is not known)
LOGGER_QUEUE_LOSS = 0.05


def logger_loss_allowance(out: Path, n: int) -> int:
    """Datagrams of one per-tick channel a recorded session of `n` ticks may lack: what the kernel counted
    as dropped at a full socket buffer, plus LOGGER_QUEUE_LOSS of the ticks for lcm-logger's own queue."""
    return udp_rcvbuf_errors(out / "udp_snmp.txt") + int(LOGGER_QUEUE_LOSS * n)


def run_in_netns(script: str, cwd: Path, timeout_s: float = 180.0) -> subprocess.CompletedProcess:
    prefix = unshare_prefix()
    assert prefix is not None
    return subprocess.run([*prefix, "sh", "-c", "set -e\n" + SETUP + script], cwd=cwd, capture_output=True,
                          text=True, timeout=timeout_s)
