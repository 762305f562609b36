"""The committed LCM classes are exactly what lcm-gen makes of lcm_types/*.lcm."""

from __future__ import annotations

import re

import pytest

from spine_module.messages import gen, types
from spine_module.messages.lcmt.sparc import spine_command_t, spine_state_t


def _normalise(text: str) -> str:
    return re.sub(r"lcm-gen \d+\.\d+\.\d+", "lcm-gen X", text)  # the version line is not drift


def test_generated_code_matches_lcm_types():
    try:
        fresh = gen.generated_files()
    except FileNotFoundError as exc:
        pytest.fail(f"cannot regenerate: {exc}")
    committed = gen.committed_files()
    assert sorted(fresh) == sorted(committed), "files differ: run `python -m spine_module.messages.gen`"
    stale = [name for name in fresh if _normalise(fresh[name]) != _normalise(committed[name])]
    assert not stale, f"{stale} drifted from lcm_types/: run `python -m spine_module.messages.gen`"


def test_python_enums_match_lcm_constants():
    for mode in types.Mode:
        assert getattr(spine_command_t, f"MODE_{mode.name}") == mode.value
    for fault in types.Fault:
        if fault.name != "NONE":
            assert getattr(spine_state_t, f"FAULT_{fault.name}") == fault.value
    lcm_faults = {n for n in dir(spine_state_t) if n.startswith("FAULT_")}
    assert lcm_faults == {f"FAULT_{f.name}" for f in types.Fault if f.name != "NONE"}
