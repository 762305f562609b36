"""robots/<robot>/README.md states the generator's masses: the table must match params.py / the json."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

from sparc_quad.robots import ROBOTS_DIR
from sparc_quad.sim.hosts import listed_hosts
from spine_module import params as P


def _table(readme: Path) -> dict[str, float]:
    rows = re.findall(r"^\| (\w+) \| ([0-9.eE+-]+) \|$", readme.read_text(), flags=re.M)
    assert rows, f"{readme}: no mass table"
    return {name: float(v) for name, v in rows}


def test_spine_readme_masses_match_params():
    got = _table(ROBOTS_DIR / "sparc_spine" / "README.md")
    want = {link.name: link.mass_kg for link in P.LINKS} | {"spine_module": P.MODULE_MASS_KG}
    assert got == pytest.approx(want, abs=5e-4)


@pytest.mark.parametrize("host", [h for h, f in listed_hosts().items() if f.generator == "splice"])
def test_quadruped_readme_masses_match_generator_json(host):
    meta = json.loads((ROBOTS_DIR / f"sparc_{host}" / f"sparc_{host}.json").read_text())
    want = dict(meta["mass_kg"]) | {f"leg_{k}": v["mass_kg"] for k, v in meta["legs"].items()}
    got = _table(ROBOTS_DIR / f"sparc_{host}" / "README.md")
    assert got == pytest.approx(want, rel=1e-5)
