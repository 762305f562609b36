"""Study specification: a base scenario and the keys a sweep overrides, checked key by key, sized before
it is expanded, and expanded into one trial config per cell and seed.

A spec is TOML with three tables:

    [study]      name, description, seeds (a count: seeds 0..n-1, or a list of seeds)
    [scenario]   the base scenario: any `sparc_quad.scenario` key (the `sparc-quad bound` options in
                 snake_case), one value each
    [grid]       scenario keys with lists of values; the trials are their cartesian product x seeds

A trial config is the base scenario with one cell's grid values on top (as a Hydra sweep overrides the
config a single run uses), so a one-cell study runs what `sparc-quad bound` runs with the same keys.
`gait = "raibert-opt"` (the Raibert bound tuned per cell by CMA-ES) adds the search keys of
`sparc_quad.study.raibert_opt`; `match_speed` (with `match_by`, ...) calibrates each cell's command,
frequency or step length until it runs that speed (`sparc_quad.study.speed_match`). A cell leaves out the
keys that do not act on its spine (the gains of a
locked or rigid-impedance spine, the controller options of a passive one), so a grid over spines and gains
runs each fixed spine once per remaining combination.
"""

from __future__ import annotations

import importlib
import itertools
import math
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

from sparc_quad.scenario import KEYS, ScenarioError
from sparc_quad.study.fixed_trial import GAITS
from sparc_quad.study.raibert_opt import OPT_KEYS as SEARCH_KEYS
from sparc_quad.study.speed_match import MATCH_KEYS

# the spine's gain keys (stiffness N/m or N*m/rad, damping N*s/m or N*m*s/rad): a report's k, d axes
SPINE_GAIN_KEYS = ("kx", "kz", "kth", "dx", "dz", "dth")
# raibert-opt's search keys (checked with the search itself: raibert_opt.check_search); `tuned` is a table
OPT_KEYS = tuple(k for k in SEARCH_KEYS if k != "tuned")
STUDY_KEYS = ("name", "description", "seeds")
MOVED = {"gait": "gait", "duration": "duration", "speeds": "speed", "slopes": "slope"}
MAX_TRIALS = 100_000  # refused at once above this (the count is computed before anything is built)
SEEDS_MAX = 10_000


class SpecError(ValueError):
    """A spec that cannot be run; the message names the key and what was wrong."""


@dataclass(frozen=True)
class Spec:
    name: str
    seeds: tuple[int, ...]
    base: dict = field(default_factory=dict)  # [scenario]
    grid: dict[str, tuple] = field(default_factory=dict)  # key -> values
    description: str = ""
    source: str = ""

    def size(self) -> int:
        """Trials before duplicates collapse: an upper bound computed without expanding."""
        return len(self.seeds) * math.prod(len(v) for v in self.grid.values())

    def trials(self) -> list[dict]:
        """One config dict per trial, in a stable order, duplicates removed."""
        return expand(self)


def _value(where: str, name: str, value):
    """One value of key `name`, checked as the scenario checks it (ints widened to float for float keys,
    so 800 and 800.0 are one trial)."""
    if name == "gait":
        if value not in GAITS:
            raise SpecError(f"{where}: {value!r} is not one of {', '.join(GAITS)}")
        return value
    if name == "match_by":
        if not isinstance(value, str):
            raise SpecError(f"{where}: expected a scenario key name, got {value!r}")
        return value
    if name in MATCH_KEYS:
        if name == "matched":
            raise SpecError(f"{where}: computed by the study (the calibration of each cell), not given")
        if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
            raise SpecError(f"{where}: expected a finite number, got {value!r}")
        return float(value) if name in ("match_speed", "match_tolerance") else value
    if name in OPT_KEYS:
        if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
            raise SpecError(f"{where}: expected a finite number, got {value!r}")
        return value
    if name not in KEYS:
        from sparc_quad.scenario.model import did_you_mean

        raise SpecError(f"{where}: unknown key{did_you_mean(name)}")
    try:
        return KEYS[name].check(value)
    except ScenarioError as exc:
        raise SpecError(f"{where}: {exc.reason}") from None


def _list(key: str, v) -> list:
    vals = v if isinstance(v, list) else [v]
    if not vals:
        raise SpecError(f"{key}: empty list")
    if len(set(map(repr, vals))) != len(vals):
        raise SpecError(f"{key}: repeated values in {vals!r}")
    return vals


def _seeds(v) -> tuple[int, ...]:
    if isinstance(v, int) and not isinstance(v, bool):
        if not 1 <= v <= SEEDS_MAX:
            raise SpecError(f"study.seeds: a count must be in [1, {SEEDS_MAX}], got {v}")
        return tuple(range(v))
    seeds = _list("study.seeds", v)
    if len(seeds) > SEEDS_MAX:
        raise SpecError(f"study.seeds: at most {SEEDS_MAX} seeds, got {len(seeds)}")
    return tuple(int(_value("study.seeds", "seed", s)) for s in seeds)


def parse_spec(data: dict, source: str = "", check: bool = True) -> Spec:
    """Check a decoded TOML document; raise SpecError naming the first bad key. `check` False skips the
    per-trial checks (each cell's whole scenario), e.g. to size a study first."""
    if not isinstance(data, dict):
        raise SpecError("spec: expected a TOML table")
    unknown = sorted(set(data) - {"study", "scenario", "grid"})
    if unknown:
        raise SpecError(f"unknown top-level table(s) {unknown}; a spec has [study], [scenario] and [grid]")
    study, base_in, grid_in = data.get("study", {}), data.get("scenario", {}), data.get("grid", {})
    for name, table in (("study", study), ("scenario", base_in), ("grid", grid_in)):
        if not isinstance(table, dict):
            raise SpecError(f"[{name}]: expected a table")
    for key in study:
        if key in MOVED:
            raise SpecError(f"study.{key}: a scenario key now: give {MOVED[key]} in [scenario] (one value) "
                            "or [grid] (a list)")
        if key not in STUDY_KEYS:
            raise SpecError(f"study.{key}: unknown key; allowed: {', '.join(STUDY_KEYS)}")
    name = study.get("name", Path(source).stem if source else "study")
    description = study.get("description", "")
    if not isinstance(name, str) or not isinstance(description, str):
        raise SpecError("study.name, study.description: expected strings")
    seeds = _seeds(study.get("seeds", 1))
    base = {}
    for key, v in base_in.items():
        if key == "seed":
            raise SpecError("scenario.seed: the seeds are [study] seeds")
        if isinstance(v, list):
            raise SpecError(f"scenario.{key}: one value here; a list of values goes in [grid]")
        base[key] = _value(f"scenario.{key}", key, v)
    grid: dict[str, tuple] = {}
    for key, v in grid_in.items():
        if key == "seed":
            raise SpecError("grid.seed: the seeds are [study] seeds")
        if key in base:
            raise SpecError(f"grid.{key}: also set in [scenario]; give it in one place")
        grid[key] = tuple(_value(f"grid.{key}", key, x) for x in _list(f"grid.{key}", v))
    spines = grid.get("spine", (base.get("spine", "impedance"),))
    for key in (*base, *grid):
        if key in KEYS and key != "spine" and not set(spines) & set(KEYS[key].spines):
            where = "grid" if key in grid else "scenario"
            raise SpecError(f"{where}.{key}: acts only with spine {' or '.join(KEYS[key].spines)}, and no "
                            f"cell has one (spine {', '.join(spines)})")
    spec = Spec(name=name, seeds=seeds, base=base, grid=grid, description=description, source=source)
    if spec.size() > MAX_TRIALS:
        raise SpecError(f"[grid] x seeds: {spec.size()} trials is more than {MAX_TRIALS}; split the study")
    if check:
        checker = trial_checker()
        for cfg in spec.trials():
            try:
                checker(cfg)
            except ValueError as exc:
                raise SpecError(f"trial {cfg}: {exc}") from None
    return spec


def trial_checker():
    """The trial function's config check."""
    return importlib.import_module("sparc_quad.study.trial").check_config


def load_spec(path: Path, check: bool = True) -> Spec:
    """Read and check a spec file; SpecError on a missing file, bad TOML or a bad key."""
    try:
        text = Path(path).read_text(encoding="utf-8")
    except OSError as exc:
        raise SpecError(f"{path}: cannot read ({exc.strerror or exc})") from None
    except UnicodeDecodeError:
        raise SpecError(f"{path}: not UTF-8 text") from None
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise SpecError(f"{path}: not valid TOML ({exc})") from None
    return parse_spec(data, source=str(path), check=check)


def expand(spec: Spec) -> list[dict]:
    keys = list(spec.grid)
    seen: set[tuple] = set()
    out: list[dict] = []
    for combo in itertools.product(*(spec.grid[k] for k in keys)):
        cell = {**spec.base, **dict(zip(keys, combo, strict=True))}
        spine = cell.get("spine", KEYS["spine"].check("impedance"))
        cell = {k: v for k, v in cell.items() if k not in KEYS or spine in KEYS[k].spines}
        for seed in spec.seeds:
            cfg = {**cell, "seed": seed}
            ident = tuple(sorted((k, repr(v)) for k, v in cfg.items()))
            if ident in seen:
                continue
            seen.add(ident)
            out.append(cfg)
    return out
