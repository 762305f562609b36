"""One scenario: every `bound` option and every study key changes the resolved scenario where it acts and
is refused (exit 2 / a SpecError naming it) where it cannot; files round-trip; a study cell is the bound
with the same keys."""

from __future__ import annotations

import json
import tomllib

import pytest

from sparc_quad.cli import build_parser, main
from sparc_quad.cli.bound import GROUPS, option, scenario_from_args
from sparc_quad.scenario import (
    GAITS,
    KEYS,
    Scenario,
    ScenarioError,
    bound_config,
    load_scenario,
    resolved,
    to_toml,
)
from sparc_quad.study.spec import SpecError, parse_spec
from sparc_quad.study.trial import config_of, trial_scenario
from tests.paths import ROOT

# `bound` options that are not scenario keys: how and where a run executes and what it writes, never what
# is simulated (each is tested where it acts: tests/integration/sim/test_quad_bound.py, test_held_steps.py)
EXECUTION = {"help", "scenario", "out", "video", "no_plots", "backend", "realtime", "lcm", "lcm_url",
             "lcm_node_states", "lcm_spin_us", "lcm_wake_latency_us", "wait_node"}
SPINES = KEYS["spine"].choices


def on_its_robot(gait: str) -> dict:
    """The keys a gait needs beside it: gait C runs only on the authors' dog."""
    return {"gait": gait, "host": "spined-dog"} if gait == "authors-raibert" else {"gait": gait}


def where_it_acts(name: str) -> dict:
    """A scenario in which key `name` acts."""
    key = KEYS[name]
    return {**on_its_robot(key.gaits[0]), "spine": key.spines[0]}


def another_value(name: str, base: Scenario):
    """A valid value of `name` other than what `base` resolves it to."""
    key = KEYS[name]
    now = getattr(resolved(base), name)
    if key.kind is bool:
        return not now if now is not None else True
    if key.choices is not None:
        return next(c for c in key.choices if c != now)
    if name == "direction":
        return -1.0 if now != -1.0 else 1.0
    if name == "host_file":  # a listed host's own file, named as a user's
        return str(ROOT / "robots" / "sparc_go1" / "host.toml")
    lo = key.lo if key.lo is not None else -1.0
    hi = key.hi if key.hi is not None else lo + 2.0
    for frac in (0.37, 0.61, 0.13):
        value = lo + frac * (hi - lo)
        value = round(value) if key.kind is int else round(value, 6)
        if value != now and KEYS[name].check(value) == value:
            return value
    raise AssertionError(name)


def cli_text(value) -> list[str]:
    return [] if isinstance(value, bool) else [str(value)]


def cli_flag(name: str, value) -> str:
    return option(name) if value is not False else "--no-" + option(name)[2:]


def test_every_bound_option_is_a_scenario_key_or_an_execution_option():
    parser = build_parser()
    bound = parser._subparsers._group_actions[0].choices["bound"]
    dests = {a.dest for a in bound._actions}
    assert dests - EXECUTION == set(KEYS)
    assert sorted(n for names in GROUPS.values() for n in names) == sorted(KEYS)


@pytest.mark.parametrize("name", [n for n in KEYS if n != "spine_path"])
def test_every_option_changes_the_resolved_scenario(name):
    """Given where it acts, the option's value is what the resolved scenario runs, and differs from the
    scenario without it; `spine_path` is below (it changes the spine, not the BoundConfig)."""
    where = where_it_acts(name)
    base = Scenario(**{k: v for k, v in where.items() if k != name})
    value = another_value(name, base)
    argv = ["bound", *[a for k, v in where.items() if k != name for a in (option(k), v)],
            cli_flag(name, value), *cli_text(value)]
    got = resolved(scenario_from_args(build_parser().parse_args(argv)))
    assert getattr(got, name) == value
    assert got != resolved(base)
    if name not in ("gait", "spine"):  # the configuration the simulator gets changes too
        try:
            changed = bound_config(got)
        except ScenarioError as exc:  # a value its robot cannot run: refused, naming a key
            assert exc.key in KEYS
            return
        assert repr(changed) != repr(bound_config(base))


def test_spine_path_changes_the_spine():
    from sparc_quad.scenario import spine_of

    assert spine_of(Scenario(), bound_config(Scenario())) is None
    s = Scenario(spine_path="node", duration=0.01)
    node = spine_of(s, bound_config(s))
    assert type(node).__name__ == "NodeSpine"
    node.close()


@pytest.mark.parametrize("name", [n for n in KEYS if KEYS[n].gaits != GAITS
                                  or set(KEYS[n].spines) != set(SPINES)])
def test_an_option_that_cannot_act_is_refused_naming_it(name, capsys):
    key = KEYS[name]
    gait = next((g for g in GAITS if g not in key.gaits), key.gaits[0])
    spine = next((s for s in SPINES if s not in key.spines), key.spines[0])
    value = another_value(name, Scenario(**on_its_robot(key.gaits[0]), spine=key.spines[0]))
    robot = [a for k, v in on_its_robot(gait).items() if k != "gait" for a in (option(k), v)]
    argv = ["bound", "--gait", gait, *robot, "--spine", spine, cli_flag(name, value), *cli_text(value),
            "--out", "/nonexistent-never-written"]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert option(name) in err and "acts only" in err and "Traceback" not in err


def test_values_out_of_range_are_refused_with_the_range(capsys):
    for argv in (["--kx", "1e12"], ["--duration", "1e9"], ["--duration", "601"], ["--seed", "-1"],
                 ["--slope", "2"], ["--imu-delay", "1.5"]):
        with pytest.raises(SystemExit) as exc:
            build_parser().parse_args(["bound", *argv])
        assert exc.value.code == 2
        assert argv[0] in capsys.readouterr().err


def test_speed_and_stride_both_given_is_refused(capsys):
    assert main(["bound", "--speed", "0.5", "--stride", "0.2", "--out", "/nonexistent-x"]) == 2
    assert "--stride" in capsys.readouterr().err


@pytest.mark.parametrize("name", list(KEYS))
def test_every_study_key_reaches_the_trial_or_is_refused(name):
    where = where_it_acts(name)
    base = {k: v for k, v in where.items() if k != name}
    value = another_value(name, Scenario(**base))
    if name == "seed":  # the seeds are the study's own key
        spec = parse_spec({"study": {"seeds": [value]}, "scenario": base}, check=False)
    else:
        spec = parse_spec({"study": {"seeds": 1}, "scenario": base,
                           "grid": {name: [value]}}, check=False)
    (trial,) = spec.trials()
    assert getattr(trial_scenario(trial), name) == value
    key = KEYS[name]
    gait = next((g for g in GAITS if g not in key.gaits), None)
    spine = next((s for s in SPINES if s not in key.spines), None)
    if gait is not None:  # another gait: refused, naming the key
        with pytest.raises(SpecError, match=name):
            parse_spec({"scenario": {**base, **on_its_robot(gait)}, "grid": {name: [value]}})
    if spine is not None:  # a spine it cannot act on in any cell: refused, naming the key
        with pytest.raises(SpecError, match=name):
            parse_spec({"scenario": {**base, "spine": spine}, "grid": {name: [value]}})


def test_files_round_trip(tmp_path):
    s = Scenario(host="spined-dog", engine="mujoco", gait="sine", kx=800, dx=8, step_length=0.08, seed=3)
    r = resolved(s)
    as_json = tmp_path / "s.json"
    as_json.write_text(json.dumps({"scenario": r.to_dict()}))
    assert load_scenario(as_json) == r
    as_toml = tmp_path / "s.toml"
    as_toml.write_text(to_toml(s))
    assert tomllib.loads(as_toml.read_text())["kx"] == 800.0
    assert load_scenario(as_toml) == s
    assert resolved(r) == r  # resolving is idempotent


def test_bad_files_name_the_key(tmp_path):
    p = tmp_path / "s.toml"
    for text, key in (('kxx = 3\n', "kxx"), ('kx = "soft"\n', "kx"),
                      ('gait = "sine"\nspeed = 1.0\n', "speed"), ('spine = "rigid"\nkx = 800\n', "kx")):
        p.write_text(text)
        with pytest.raises(ScenarioError) as exc:
            load_scenario(p)
        assert exc.value.key == key and str(p) in str(exc.value)
    p.write_bytes(b"\xff\xfe")
    with pytest.raises(ScenarioError, match="not UTF-8"):
        load_scenario(p)


def test_a_study_cell_is_the_bound_with_the_same_keys():
    """The issue's case: a spec written as a user would (host, engine, gait, gains, no hidden keys) runs
    what `sparc-quad bound` runs with the same options (the authors' run, forward), seed by seed."""
    spec = parse_spec({"study": {"seeds": 3}, "scenario": {"host": "spined-dog", "engine": "mujoco",
                                                          "gait": "sine", "step_length": 0.08, "kx": 800,
                                                          "dx": 8, "duration": 4.0}})
    for trial in spec.trials():
        argv = ["bound", "--host", "spined-dog", "--engine", "mujoco", "--gait", "sine", "--step-length",
                "0.08", "--kx", "800", "--dx", "8", "--duration", "4", "--seed", str(trial["seed"])]
        from_cli = bound_config(scenario_from_args(build_parser().parse_args(argv)))
        assert repr(config_of(trial)) == repr(from_cli)
        assert from_cli.gait.variant == "authors" and from_cli.gait.direction == 1.0
        assert from_cli.spine.d == (8.0, 5.0, 0.5)


def test_gait_a_defaults_are_one_set_on_every_host():
    solo = resolved(Scenario(gait="sine"))
    dog = resolved(Scenario(gait="sine", host="spined-dog"))
    assert (solo.variant, dog.variant) == ("literal", "authors")
    assert (solo.kx, solo.dx, solo.schedule) == (dog.kx, dog.dx, dog.schedule) == (800.0, 8.0, True)
    assert dog.step_length == 0.08 and dog.base_motion == "authors-cvel" and dog.imu_noise == 0.0
