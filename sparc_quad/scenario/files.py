"""Scenarios on disk: read from TOML or JSON, written as `scenario.json` (resolved, with provenance and
units) or as TOML a person edits.

`load_scenario` takes a scenario file (`.toml`, or `.json` holding the keys), a `scenario.json` that a bound
wrote, or a study trial record (both hold the run under "scenario"): anything that ran can be run again.
"""

from __future__ import annotations

import json
import tomllib
from pathlib import Path
from typing import Any

from sparc_quad.jsonfmt import json_text
from sparc_quad.provenance import code_version, git_describe
from sparc_quad.scenario.model import KEYS, Scenario, ScenarioError

SCENARIO_FILE = "scenario.json"
DOC_VERSION = 1


def read_table(path: Path) -> dict[str, Any]:
    """The scenario keys held by `path` (TOML or JSON; a "scenario" table when the file has one)."""
    path = Path(path)
    try:
        if path.is_dir():
            raise ScenarioError(None, f"{path}: is a folder, not a scenario file")
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        raise ScenarioError(None, f"{path}: cannot read ({exc.strerror or exc})") from None
    except UnicodeDecodeError:
        raise ScenarioError(None, f"{path}: not UTF-8 text") from None
    try:
        data = tomllib.loads(text) if path.suffix.lower() == ".toml" else json.loads(text)
    except (tomllib.TOMLDecodeError, ValueError) as exc:
        kind = "TOML" if path.suffix.lower() == ".toml" else "JSON"
        raise ScenarioError(None, f"{path}: not valid {kind} ({exc})") from None
    if isinstance(data, dict) and isinstance(data.get("scenario"), dict):
        data = data["scenario"]
    if not isinstance(data, dict):
        raise ScenarioError(None, f"{path}: expected a table of scenario keys")
    return data


def load_scenario(path: Path) -> Scenario:
    """The scenario in `path`; ScenarioError naming the file and the key on anything wrong."""
    data = read_table(path)
    try:
        return Scenario.from_dict(data)
    except ScenarioError as exc:
        raise ScenarioError(exc.key, f"{exc.reason} (in {path})") from None


def units() -> dict[str, str]:
    """Each scenario key's unit ("" for a count, a name or a fraction)."""
    return {name: key.unit for name, key in KEYS.items()}


def document(scenario: Scenario, *, metric_units: dict[str, str] | None = None) -> dict[str, Any]:
    """What `scenario.json` holds: the resolved scenario, the code that ran it, the units of its keys and
    of the metrics written beside it."""
    from sparc_quad.scenario.resolve import resolved

    doc: dict[str, Any] = {"version": DOC_VERSION, "scenario": resolved(scenario).to_dict(),
                           "code_version": code_version(), "git_describe": git_describe(), "units": units()}
    if metric_units is not None:
        doc["metric_units"] = metric_units
    return doc


def write_scenario(folder: Path, scenario: Scenario, *, metric_units: dict[str, str] | None = None) -> Path:
    path = Path(folder) / SCENARIO_FILE
    path.write_text(json_text(document(scenario, metric_units=metric_units), indent=2) + "\n")
    return path


def to_toml(scenario: Scenario) -> str:
    """The scenario as TOML, one key a line with its unit and help as a comment (None keys left out: their
    robot's and gait's defaults apply)."""
    lines = []
    for name, value in scenario.to_dict(skip_none=True).items():
        key = KEYS[name]
        text = json.dumps(value) if not isinstance(value, bool) else ("true" if value else "false")
        note = f"  # {key.unit}" if key.unit else ""
        lines.append(f"{name} = {text}{note}")
    return "\n".join(lines) + "\n"
