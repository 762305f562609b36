"""Checking a host file as a whole: its keys and URDF (`sim.host_file`), its standing pose and the scenario
keys it gives as defaults (`sparc-quad robots check`)."""

from __future__ import annotations

from pathlib import Path

from sparc_quad.scenario.model import KEYS
from sparc_quad.sim.host_file import HostFileError, load_host_file
from sparc_quad.sim.quadruped_world import WorldConfig


def check_host(path: Path) -> list[str]:
    """Every problem of the host file at `path`, one line each: its keys, its URDF (missing link, wrong leg
    count or joints), its standing pose (legs too short for the stance), its defaults (scenario keys).
    Empty when the host can be spliced and bounded."""
    try:
        host = load_host_file(path)
    except HostFileError as exc:
        return exc.problems
    problems = []
    if host.generator == "splice":
        from sparc_quad.sim.quadruped_urdf import quadruped

        try:
            model = quadruped(host)
        except (ValueError, OSError, KeyError, ImportError) as exc:
            return [f"model: {exc}"]
        stand = WorldConfig.stand_height_m
        for key, leg in sorted(model.meta["legs"].items()):
            if leg["thigh_m"] + leg["shank_m"] <= stand:
                problems.append(f"legs: leg {key} reaches {leg['thigh_m'] + leg['shank_m']:.3f} m, not the "
                                f"standing hip height {stand:g} m (no standing pose)")
    for gait, keys in host.defaults.items():
        if gait not in KEYS["gait"].choices:
            problems.append(f"defaults.{gait}: not a gait ({', '.join(KEYS['gait'].choices)})")
            continue
        for key, value in keys.items():
            if key not in KEYS or not KEYS[key].nullable:
                problems.append(f"defaults.{gait}.{key}: not a key a host sets (only those whose default "
                                "depends on the robot)")
                continue
            try:
                KEYS[key].check(value)
            except ValueError as exc:
                problems.append(f"defaults.{gait}.{exc}")
    return problems
