"""Study specification: a TOML file read, checked key by key, and expanded into one config per trial.

A spec has a `[study]` table (gait, duration s, seeds, speeds m/s, slopes rad) and a `[grid]` table whose
keys are `sparc-quad bound` options in snake_case with lists of values, plus `spine`. The trials are the
cartesian product; spines that do not render an impedance (rigid, rigid-impedance) do not vary k, d, so
their repeats collapse into one trial per remaining combination.
"""

from __future__ import annotations

import importlib
import itertools
import math
import tomllib
from dataclasses import dataclass
from pathlib import Path

GAITS = ("sine", "raibert", "raibert-opt")
SPINES = ("impedance", "passive", "rigid", "rigid-impedance")
# spines whose k, d are fixed by the variant itself: the grid's k, d do not apply to them
FIXED_SPINES = ("rigid", "rigid-impedance")
# spine impedance options (stiffness N/m or N*m/rad, damping N*s/m or N*m*s/rad)
SPINE_GAIN_KEYS = ("kx", "kz", "kth", "dx", "dz", "dth", "ktheta", "dtheta")
# `sparc-quad bound` / trial options (snake_case) a grid may vary, by type; the trial function's own
# check (sparc_quad.study.trial.check_config, when present) then judges each expanded config
NONNEG_KEYS = (
    *SPINE_GAIN_KEYS,
    "frequency",
    "stride",
    "step_height",
    "duty",
    "step_length",
    "spine_rate_hz",
    "hip_depth",
    "settle",
    "body_kp",
    "body_kd",
    "raibert_gain",
    "opt_duration",
    "imu_noise",
)
SIGNED_KEYS = ("direction", "phase_offset", "imu_bias")
INT_KEYS = ("popsize", "iterations", "opt_seed", "opt_restarts", "opt_trial_seeds", "imu_delay",
            "latency_steps")
NUMERIC_KEYS = NONNEG_KEYS + SIGNED_KEYS + INT_KEYS
BOOL_KEYS = ("friction_comp", "adapt_frequency", "schedule")
STR_KEYS = ("host", "engine", "variant")
STUDY_KEYS = ("gait", "duration", "seeds", "speeds", "slopes", "name", "description")
MAX_TRIALS = 100_000


class SpecError(ValueError):
    """A spec that cannot be run; the message names the key and what was wrong."""


@dataclass(frozen=True)
class Spec:
    name: str
    gaits: tuple[str, ...]
    duration_s: float
    seeds: tuple[int, ...]
    speeds_m_s: tuple[float, ...]
    slopes_rad: tuple[float, ...]
    grid: dict[str, tuple]  # key -> values, `spine` included
    source: str = ""

    def trials(self) -> list[dict]:
        """One config dict per trial, in a stable order, duplicates removed."""
        return expand(self)


def _number(key: str, v, *, positive: bool = False, integer: bool = False) -> float | int:
    if isinstance(v, bool) or not isinstance(v, int | float):
        raise SpecError(f"{key}: expected a number, got {v!r}")
    if not math.isfinite(v):
        raise SpecError(f"{key}: expected a finite number, got {v!r}")
    if integer and (not isinstance(v, int)):
        raise SpecError(f"{key}: expected an integer, got {v!r}")
    if positive and v <= 0:
        raise SpecError(f"{key}: must be > 0, got {v!r}")
    return v


def _list(key: str, v) -> list:
    vals = v if isinstance(v, list) else [v]
    if not vals:
        raise SpecError(f"{key}: empty list")
    if len(set(map(repr, vals))) != len(vals):
        raise SpecError(f"{key}: repeated values in {vals!r}")
    return vals


def parse_spec(data: dict, source: str = "") -> Spec:
    """Check a decoded TOML document; raise SpecError naming the first bad key."""
    if not isinstance(data, dict):
        raise SpecError("spec: expected a TOML table")
    unknown = sorted(set(data) - {"study", "grid"})
    if unknown:
        raise SpecError(f"unknown top-level table(s) {unknown}; a spec has [study] and [grid]")
    study = data.get("study")
    if not isinstance(study, dict):
        raise SpecError("[study]: missing table (gait, duration, seeds, speeds, slopes)")
    grid = data.get("grid", {})
    if not isinstance(grid, dict):
        raise SpecError("[grid]: expected a table")
    bad = sorted(set(study) - set(STUDY_KEYS))
    if bad:
        raise SpecError(f"study.{bad[0]}: unknown key; allowed: {', '.join(STUDY_KEYS)}")
    if "gait" not in study:
        raise SpecError(f"study.gait: missing; one of {', '.join(GAITS)} (or a list of them)")
    gaits = _list("study.gait", study["gait"])
    for g in gaits:
        if g not in GAITS:
            raise SpecError(f"study.gait: {g!r} is not one of {', '.join(GAITS)}")
    if "duration" not in study:
        raise SpecError("study.duration: missing (simulated seconds per trial)")
    duration = float(_number("study.duration", study["duration"], positive=True))
    seeds_v = study.get("seeds", 1)
    if isinstance(seeds_v, int) and not isinstance(seeds_v, bool):
        if seeds_v < 1:
            raise SpecError(f"study.seeds: a count must be >= 1, got {seeds_v}")
        seeds = list(range(seeds_v))
    else:
        seeds = [_number("study.seeds", s, integer=True) for s in _list("study.seeds", seeds_v)]
        if any(s < 0 for s in seeds):
            raise SpecError(f"study.seeds: seeds must be >= 0, got {seeds}")
    speeds = [float(_number("study.speeds", v)) for v in _list("study.speeds", study.get("speeds", [0.9]))]
    slopes = [float(_number("study.slopes", v)) for v in _list("study.slopes", study.get("slopes", [0.0]))]
    for s in slopes:
        if abs(s) > 0.5:
            raise SpecError(f"study.slopes: {s} rad is steeper than 0.5 rad")
    name = study.get("name", Path(source).stem if source else "study")
    if not isinstance(name, str):
        raise SpecError(f"study.name: expected a string, got {name!r}")

    out_grid: dict[str, tuple] = {}
    if "spine" not in grid:
        out_grid["spine"] = ("impedance",)
    for key, v in grid.items():
        vals = _list(f"grid.{key}", v)
        if key == "spine":
            for s in vals:
                if s not in SPINES:
                    raise SpecError(f"grid.spine: {s!r} is not one of {', '.join(SPINES)}")
        elif key in NUMERIC_KEYS:
            for x in vals:
                _number(f"grid.{key}", x, integer=key in INT_KEYS)
                if key not in SIGNED_KEYS and x < 0:
                    raise SpecError(f"grid.{key}: must be >= 0, got {x}")
            if key in ("frequency", "stride") and any(x <= 0 for x in vals):
                raise SpecError(f"grid.{key}: must be > 0, got {vals}")
            if key == "duty" and any(not 0 < x < 1 for x in vals):
                raise SpecError(f"grid.duty: must be in (0, 1), got {vals}")
            # 800 and 800.0 are one trial: numbers are floats (counts stay integers) so hashes agree
            vals = [int(x) if key in INT_KEYS else float(x) for x in vals]
        elif key in BOOL_KEYS:
            if any(not isinstance(x, bool) for x in vals):
                raise SpecError(f"grid.{key}: expected true/false, got {vals}")
        elif key in STR_KEYS:
            if any(not isinstance(x, str) for x in vals):
                raise SpecError(f"grid.{key}: expected strings, got {vals}")
        elif key in ("gait", "duration", "seed", "seeds", "speed", "speeds", "slope", "slopes"):
            raise SpecError(f"grid.{key}: set it in [study], not [grid]")
        else:
            allowed = ", ".join(("spine", *NUMERIC_KEYS, *BOOL_KEYS, *STR_KEYS))
            raise SpecError(f"grid.{key}: unknown option; allowed: {allowed}")
        out_grid[key] = tuple(vals)
    spec = Spec(
        name=name,
        gaits=tuple(gaits),
        duration_s=duration,
        seeds=tuple(int(s) for s in seeds),
        speeds_m_s=tuple(speeds),
        slopes_rad=tuple(slopes),
        grid=out_grid,
        source=source,
    )
    trials = spec.trials()
    if len(trials) > MAX_TRIALS:
        raise SpecError(f"[grid]: {len(trials)} trials is more than {MAX_TRIALS}; split the study")
    check = trial_checker()
    if check is not None:
        for cfg in trials:
            try:
                check(cfg)
            except ValueError as exc:
                raise SpecError(f"trial {cfg}: {exc}") from None
    return spec


def trial_checker():
    """The trial function's config check, if the trial module provides one."""
    try:
        trial = importlib.import_module("sparc_quad.study.trial")
    except ModuleNotFoundError as exc:
        if exc.name != "sparc_quad.study.trial":
            raise
        return None
    return getattr(trial, "check_config", None)


def load_spec(path: Path) -> Spec:
    """Read and check a spec file; SpecError on a missing file, bad TOML or a bad key."""
    try:
        text = Path(path).read_text()
    except OSError as exc:
        raise SpecError(f"{path}: cannot read ({exc.strerror or exc})") from None
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise SpecError(f"{path}: not valid TOML ({exc})") from None
    return parse_spec(data, source=str(path))


def expand(spec: Spec) -> list[dict]:
    keys = list(spec.grid)
    seen: set[tuple] = set()
    out: list[dict] = []
    for gait, speed, slope in itertools.product(spec.gaits, spec.speeds_m_s, spec.slopes_rad):
        for combo in itertools.product(*(spec.grid[k] for k in keys)):
            cell = dict(zip(keys, combo, strict=True))
            if cell.get("spine") in FIXED_SPINES:
                cell = {k: v for k, v in cell.items() if k not in SPINE_GAIN_KEYS}
            for seed in spec.seeds:
                cfg = {
                    "gait": gait,
                    "duration": spec.duration_s,
                    "speed": speed,
                    "slope": slope,
                    "seed": seed,
                    **cell,
                }
                ident = tuple(sorted((k, repr(v)) for k, v in cfg.items()))
                if ident in seen:
                    continue
                seen.add(ident)
                out.append(cfg)
    return out
