"""How a performance script ends: the host facts beside its numbers, one printed line per result, the JSON."""

from __future__ import annotations

import json
import os
import platform
from pathlib import Path


def cpu_model() -> str:
    """The CPU's model name (/proc/cpuinfo; else `platform.processor()`): the same code's ratios differ from
    one host CPU to another (notebook/2026-12-03-amd-host.md)."""
    info = Path("/proc/cpuinfo")
    if info.exists():
        for line in info.read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    return platform.processor() or "unknown"


def host_facts() -> dict[str, object]:
    """Load average (1, 5, 15 min), Python, pinocchio, machine and CPU model: what a ratio was measured on."""
    import pinocchio as pin  # here, not at import: bench/summary.py needs only cpu_model

    load = Path("/proc/loadavg")
    return {"loadavg": load.read_text().split()[:3] if load.exists() else None,
            "python": platform.python_version(), "pinocchio": pin.__version__, "machine": platform.machine(),
            "cpu": cpu_model(), "cpus": os.cpu_count()}


def emit(result: dict[str, object], json_path: Path | None, width: int = 28) -> None:
    """Print `result` a line per key (floats to 3 decimals) and write it to `json_path` when given."""
    for key, v in result.items():
        print(f"{key:{width}s} {v:.3f}" if isinstance(v, float) else f"{key:{width}s} {v}")
    if json_path:
        json_path.parent.mkdir(parents=True, exist_ok=True)
        json_path.write_text(json.dumps(result, indent=2))
