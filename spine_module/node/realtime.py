"""Real-time set-up of the node's process for a torso computer: CPU affinity, SCHED_FIFO priority,
locked memory, a CPU wake-latency request, and a frozen garbage collector.

Each step says what it did or why it could not: `--cpu` and `--rt-priority` were asked for explicitly, so
failing them is an `RtSetupError` (the node refuses to run with less than it was asked for); memory
locking and the wake-latency request are best effort (`lock_memory`, `hold_wake_latency`), reported and
skipped where the kernel or the permissions refuse.
Linux only (os.sched_setaffinity / os.sched_setscheduler, mlockall from libc).
"""

from __future__ import annotations

import ctypes
import ctypes.util
import errno
import gc
import os
import struct
import sys
from dataclasses import dataclass

MCL_CURRENT, MCL_FUTURE = 1, 2  # <sys/mman.h> on Linux
# With a real-time priority, a bus thread holding the interpreter lock must hand it to the loop within this
# (CPython's default is 5 ms, five whole ticks); measured on bench/can_loop.py with SCHED_FIFO at load ~1.5:
# 0.984-0.994 of 1 kHz with 5 ms, 0.996-0.998 with 0.2 ms.
RT_SWITCH_INTERVAL_S = 0.0002
# The kernel's PM QoS interface (Documentation/power/pm_qos_interface.rst): while a process keeps this file
# open with a 32-bit value written, no CPU enters an idle state whose exit latency exceeds that many us.
# With 0 an idle CPU polls instead of halting, so a message for a blocked peer is taken at once instead of
# after the CPU's wake-up (on a KVM guest with the haltpoll driver: an exit to the host, 40-70 us per
# message measured; docs/performance.md "LCM lockstep"). cyclictest asks for 0 by default for the same
# reason. It costs power while the process lives, never CPU time that runnable work could have had.
CPU_DMA_LATENCY = "/dev/cpu_dma_latency"
WAKE_LATENCY_DEFAULT_US = 0
_wake_latency_fds: list[int] = []  # held open for the life of the process: closing drops the request


class RtSetupError(RuntimeError):
    """A requested real-time setting could not be applied; the message says why and what to do."""


@dataclass(frozen=True)
class RtOptions:
    cpu: int | None = None  # pin the process to this CPU
    rt_priority: int | None = None  # SCHED_FIFO priority 1..99
    lock_memory: bool = False  # mlockall(MCL_CURRENT | MCL_FUTURE), best effort
    wake_latency_us: int | None = None  # PM QoS CPU wake-latency bound, us (hold_wake_latency), best effort
    freeze_gc: bool = False  # see freeze_startup_objects: call it once everything is built instead


def _set_cpu(cpu: int) -> str:
    if not hasattr(os, "sched_setaffinity"):
        raise RtSetupError("--cpu needs Linux (os.sched_setaffinity is not available here)")
    allowed = sorted(os.sched_getaffinity(0))
    if cpu not in allowed:
        raise RtSetupError(f"--cpu {cpu}: not a CPU this process may run on (allowed: {allowed})")
    os.sched_setaffinity(0, {cpu})
    return f"pinned to CPU {cpu}"


def _set_priority(priority: int) -> str:
    if not hasattr(os, "sched_setscheduler"):
        raise RtSetupError("--rt-priority needs Linux (os.sched_setscheduler is not available here)")
    lo, hi = os.sched_get_priority_min(os.SCHED_FIFO), os.sched_get_priority_max(os.SCHED_FIFO)
    if not lo <= priority <= hi:
        raise RtSetupError(f"--rt-priority {priority}: SCHED_FIFO priorities are {lo}..{hi}")
    try:
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(priority))
    except PermissionError:
        raise RtSetupError(
            f"--rt-priority {priority}: SCHED_FIFO not permitted for this user. Run as root, grant "
            "CAP_SYS_NICE (setcap cap_sys_nice+ep on the interpreter), or allow it in "
            "/etc/security/limits.conf ('<user> - rtprio 99'); or run without --rt-priority") from None
    except OSError as exc:
        raise RtSetupError(f"--rt-priority {priority}: sched_setscheduler failed: {exc}") from None
    sys.setswitchinterval(RT_SWITCH_INTERVAL_S)
    return (f"SCHED_FIFO priority {priority} (threads started from now on inherit it); interpreter switch "
            f"interval {RT_SWITCH_INTERVAL_S * 1e6:.0f} us")


def _lock_memory() -> str:
    name = ctypes.util.find_library("c")
    if name is None:
        return "memory not locked: libc not found"
    libc = ctypes.CDLL(name, use_errno=True)
    if libc.mlockall(MCL_CURRENT | MCL_FUTURE) == 0:
        return "memory locked (mlockall)"
    err = ctypes.get_errno()
    why = {errno.EPERM: "not permitted (needs CAP_IPC_LOCK or root)",
           errno.ENOMEM: "over RLIMIT_MEMLOCK (raise 'memlock' in /etc/security/limits.conf or ulimit -l)"}
    return f"memory not locked: {why.get(err, os.strerror(err))}"


def hold_wake_latency(us: int, path: str = CPU_DMA_LATENCY) -> str:
    """Ask the kernel to keep every CPU's idle exit latency at or below `us` microseconds for as long as
    this process lives (PM QoS, `CPU_DMA_LATENCY`). Best effort: where the file is missing or not
    writable (it needs root) the reason is returned and nothing changes."""
    if not 0 <= us <= 2**31 - 1:
        raise ValueError(f"wake latency must be 0..{2**31 - 1} us, got {us!r}")
    try:
        fd = os.open(path, os.O_WRONLY)
    except FileNotFoundError:
        return f"CPU wake latency not requested: {path} does not exist (a kernel without PM QoS)"
    except PermissionError:
        return f"CPU wake latency not requested: {path} is not writable by this user (needs root)"
    except OSError as exc:
        return f"CPU wake latency not requested: {path}: {exc.strerror}"
    try:
        os.write(fd, struct.pack("=i", us))
    except OSError as exc:
        os.close(fd)
        return f"CPU wake latency not requested: writing {path} failed: {exc.strerror}"
    _wake_latency_fds.append(fd)
    return f"CPU wake latency held at <= {us} us while this process runs ({path})"


def release_wake_latency() -> None:
    """Drop this process's wake-latency requests (they also end when the process exits)."""
    while _wake_latency_fds:
        os.close(_wake_latency_fds.pop())


def apply(options: RtOptions) -> list[str]:
    """Apply the options to this process; returns one line per setting saying what happened.

    Raises RtSetupError for a CPU or priority that cannot be had."""
    done = []
    if options.cpu is not None:
        done.append(_set_cpu(options.cpu))
    if options.lock_memory:
        done.append(_lock_memory())
    if options.wake_latency_us is not None:
        done.append(hold_wake_latency(options.wake_latency_us))
    if options.rt_priority is not None:
        done.append(_set_priority(options.rt_priority))
    if options.freeze_gc:
        done.append(freeze_startup_objects())
    return done


def freeze_startup_objects() -> str:
    """Collect once, then move every live object (models, modules, numba's compiled code) out of the
    collector's reach: the loop's full collections then walk only what the loop allocated, so a gen-2
    pause drops from tens of milliseconds to well under one."""
    gc.collect()
    gc.freeze()
    return f"garbage collector: {gc.get_freeze_count()} start-up objects frozen"
