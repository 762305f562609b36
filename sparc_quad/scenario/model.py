"""`Scenario`: the one description of a bound, its keys' units, ranges and defaults, checked in one place.

Every way into a run builds one: `sparc-quad bound` options (each key is an option, `--step-length` for
`step_length`), a study cell (the spec's `[scenario]` with the `[grid]` values of that cell as overrides, as a
Hydra sweep overrides the config a single run uses), a `scenario.json`/`.toml` file and Python. A key left
at None takes the default of its robot and gait (`resolve.resolved` fills it in, in one place); a key that
cannot act in the scenario (a Raibert speed in the open-loop sine gait, gains on a locked spine) is refused,
never ignored. Units are SI and named in each key's `unit`.
"""

from __future__ import annotations

import difflib
import math
from collections.abc import Mapping
from dataclasses import dataclass, field, fields, replace
from typing import Any

from sparc_quad.limits import SEED_MAX, SIM_DURATION_MAX_S, SIM_DURATION_MIN_S
from sparc_quad.sim import spined_dog
from sparc_quad.sim.engines import DEFAULT_ENGINE, ENGINES
from sparc_quad.sim.hosts import DEFAULT_HOST, HOSTS
from sparc_quad.sim.quadruped_world import BASE_MOTIONS
from sparc_quad.sim.spine_drive import SPINE_VARIANTS
from spine_module.messages import codec

GAITS = ("raibert", "sine", "authors-raibert")
SINE_VARIANTS = ("authors", "literal")
SPINE_PATHS = ("direct", "node")
DURATION_MAX_S = SIM_DURATION_MAX_S


class ScenarioError(ValueError):
    """A scenario that cannot run: `key` is the offending key (None: the scenario as a whole)."""

    def __init__(self, key: str | None, message: str):
        super().__init__(f"{key}: {message}" if key else message)
        self.key = key
        self.reason = message


@dataclass(frozen=True)
class Key:
    """What one scenario key is: its type, unit, range or choices, and where it acts."""

    name: str
    kind: type  # float, int, bool or str
    unit: str
    help: str
    lo: float | None = None
    hi: float | None = None
    lo_open: bool = False
    hi_open: bool = False
    choices: tuple[str, ...] | None = None
    gaits: tuple[str, ...] = GAITS  # the gaits it acts in
    spines: tuple[str, ...] = SPINE_VARIANTS  # the spines it acts on
    nullable: bool = False  # None means "the robot's and gait's default"

    def span(self) -> str:
        left, right = "(" if self.lo_open else "[", ")" if self.hi_open else "]"

        def show(v: float | None, inf: str) -> str:
            return inf if v is None else str(int(v)) if self.kind is int else f"{v:.6g}"

        return f"{left}{show(self.lo, '-inf')}, {show(self.hi, 'inf')}{right}"

    def check(self, value: Any) -> Any:
        """The value as the scenario holds it (ints widened to float for float keys); ScenarioError else."""
        if value is None:
            if self.nullable:
                return None
            raise ScenarioError(self.name, "must be given (it has no robot- or gait-dependent default)")
        if self.kind is bool:
            if not isinstance(value, bool):
                raise ScenarioError(self.name, f"expected true or false, got {value!r}")
            return value
        if self.kind is str:
            if not isinstance(value, str):
                raise ScenarioError(self.name, f"expected a string, got {value!r}")
            if self.choices is not None and value not in self.choices:
                near = difflib.get_close_matches(value, self.choices, n=1)
                hint = f" (did you mean {near[0]!r}?)" if near else ""
                raise ScenarioError(self.name,
                                    f"must be one of {', '.join(self.choices)}, got {value!r}{hint}")
            return value
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise ScenarioError(self.name, f"expected {'an integer' if self.kind is int else 'a number'}, "
                                           f"got {value!r}")
        if self.kind is int:
            if isinstance(value, float) and not value.is_integer():
                raise ScenarioError(self.name, f"expected an integer, got {value!r}")
            value = int(value)
        else:
            if not math.isfinite(value):
                raise ScenarioError(self.name, f"must be finite, got {value!r}")
            value = float(value)
        lo, hi = self.lo, self.hi
        if (lo is not None and (value < lo or (self.lo_open and value == lo))) or \
           (hi is not None and (value > hi or (self.hi_open and value == hi))):
            raise ScenarioError(self.name, f"must be in {self.span()}{f' {self.unit}' if self.unit else ''}, "
                                           f"got {value!r}")
        return value


def _key(default: Any, kind: type, help: str, unit: str = "", **rest: Any) -> Any:
    return field(default=default, metadata={"key": dict(kind=kind, unit=unit, help=help, **rest)})


_RAIBERT, _SINE, _GAIT_C = ("raibert",), ("sine",), ("authors-raibert",)
_SPEED = (*_RAIBERT, *_GAIT_C)  # speed-commanded gaits
_RENDERED = ("impedance", "passive")  # spines whose k, d the scenario sets
_MOTOR = ("impedance", "rigid-impedance")  # spines a motor renders (controller options act)
K_MAX, D_MAX = codec.K_MAX, codec.D_MAX  # what the spine node's command accepts


@dataclass(frozen=True)
class Scenario:
    """One bound: robot, engine, gait and its parameters, spine and its gains, estimator, seed, duration,
    judged window. Immutable; `replace` or `with_overrides` makes another. Keys at None take their robot's
    and gait's defaults (`sparc_quad.scenario.resolved`)."""

    # the robot and its world
    host: str = _key(DEFAULT_HOST, str, "host robot, one listed under robots/ (a host.toml in its folder)",
                     choices=HOSTS)
    host_file: str | None = _key(None, str, "a host.toml of a quadruped of your own (docs/hosts.md): the "
                                 "spine is spliced into it on first use; replaces host", "path",
                                 nullable=True)
    engine: str = _key(DEFAULT_ENGINE, str, "physics engine (mujoco needs the [mujoco] extra)",
                       choices=tuple(ENGINES))
    slope: float = _key(0.0, float, "ground slope, > 0 uphill", "rad", lo=-math.pi / 2, hi=math.pi / 2,
                        lo_open=True, hi_open=True)
    seed: int = _key(0, int, "seed of every random number of the run: the estimator's noise and the "
                     "replicate's perturbation of start phase, initial pitch and speed, friction and mass "
                     "(sparc_quad/sim/seed_variation.py; 0 is the nominal robot)", lo=0, hi=SEED_MAX)
    duration: float = _key(10.0, float, "simulated time (the 1 kHz log is kept in memory)", "s",
                           lo=SIM_DURATION_MIN_S, hi=DURATION_MAX_S)
    settle: float = _key(1.0, float, "the judged window starts this long after the gait's start-up (stand, "
                         "speed ramp, the authors' spine switch), and at half the run at the latest", "s",
                         lo=0.0, hi=DURATION_MAX_S)
    latency_steps: int = _key(0, int, "every joint torque is applied this many 1 ms physics steps late",
                              "steps", lo=0, hi=1000)
    joint_damping: float | None = _key(None, float, "viscous damping of every joint (default: 0; 0.1 in "
                                       "authors-raibert on spined-dog, the authors' later dog model)",
                                       "N*m*s/rad", lo=0.0, hi=100.0, nullable=True)
    joint_friction: float | None = _key(None, float, "dry friction of every joint (default: 0; 0.1 in "
                                        "authors-raibert on spined-dog)", "N*m", lo=0.0, hi=100.0,
                                        nullable=True)
    leg_torque_limit: float | None = _key(None, float, "torque limit of every leg motor (default: 120, the "
                                          "authors' later dog model; gaits A and B use the host's)", "N*m",
                                          lo=0.0, hi=1000.0, lo_open=True, gaits=_GAIT_C, nullable=True)
    # the gait
    gait: str = _key("raibert", str, "raibert: the project's speed-commanded Raibert bound (gait B); sine: "
                     "the SPARC authors' open-loop sine bound (gait A); authors-raibert: the authors' own "
                     "speed-commanded Raibert bound for their spined dog (gait C)", choices=GAITS)
    speed: float | None = _key(None, float, "target forward speed (default: 0.6 raibert, 1.3 "
                               "authors-raibert)", "m/s", lo=0.0, hi=10.0, gaits=_SPEED, nullable=True)
    stride: float | None = _key(None, float, "stride length; sets the target speed to stride x frequency "
                                "(instead of speed)", "m", lo=0.0, hi=2.0, lo_open=True, gaits=_RAIBERT,
                                nullable=True)
    frequency: float | None = _key(None, float, "stride frequency (default: 4.0 raibert, 3.1 sine and "
                                   "authors-raibert)", "Hz",
                                   lo=0.0, hi=10.0, lo_open=True, nullable=True)
    step_height: float | None = _key(None, float, "swing foot clearance (default: 0.07 raibert, 0.06 sine, "
                                     "0.08 authors-raibert)",
                                     "m", lo=0.0, hi=0.2, nullable=True)
    duty: float | None = _key(None, float, "stance fraction of each leg pair (default: 0.5 at <= 0.3 m/s to "
                              "0.45 at >= 0.6 m/s)", lo=0.0, hi=1.0, lo_open=True, hi_open=True,
                              gaits=_RAIBERT, nullable=True)
    body_kp: float | None = _key(None, float, "stance attitude servo per body (default: 6; 0 = off)",
                                 "N*m/rad", lo=0.0, hi=1000.0, gaits=_RAIBERT, nullable=True)
    body_kd: float | None = _key(None, float, "its damping (default: 0.6)", "N*m*s/rad", lo=0.0, hi=100.0,
                                 gaits=_RAIBERT, nullable=True)
    height: float | None = _key(None, float, "hip height above the ground that the stance holds, and the "
                                "standing start's (default: 0.22)", "m", lo=0.05, hi=1.0, gaits=_RAIBERT,
                                nullable=True)
    roll_kp: float | None = _key(None, float, "roll servo: left/right stance force difference per rad of "
                                 "roll (default: 80)", "N/rad", lo=0.0, hi=1e4, gaits=_RAIBERT, nullable=True)
    roll_kd: float | None = _key(None, float, "its damping (default: 4)", "N*s/rad", lo=0.0, hi=1e3,
                                 gaits=_RAIBERT, nullable=True)
    phase_offset: float | None = _key(None, float, "front stance starts this fraction of a stride after "
                                      "the hind (default: 0.5)", lo=0.0, hi=1.0, hi_open=True, gaits=_RAIBERT,
                                      nullable=True)
    raibert_gain: float | None = _key(None, float, "k_v of the touchdown law (default: 0.1)", "s", lo=0.0,
                                      hi=1.0, gaits=_RAIBERT, nullable=True)
    variant: str | None = _key(None, str, "gait A's port: authors (their start pose, control clock and "
                               "swing arc; the default on spined-dog) or literal (the first port, standing "
                               "start; the default elsewhere)", choices=SINE_VARIANTS, gaits=_SINE,
                               nullable=True)
    step_length: float | None = _key(None, float, "L, half the fore-aft foot excursion about the hip "
                                     "(x = L cos phi); default 0.08 on spined-dog (the authors' run at 0.88 "
                                     "m/s; their released default 0.12 falls), 0.12 elsewhere", "m", lo=0.0,
                                     hi=0.3, gaits=_SINE, nullable=True)
    hip_depth: float | None = _key(None, float, "foot below the hip in stance (default: 0.23)", "m", lo=0.05,
                                   hi=0.6, gaits=_SINE, nullable=True)
    direction: float | None = _key(None, float, "literal port: +1 the authors' x read as the robot's, -1 "
                                   "reversed (default: +1)", lo=-1.0, hi=1.0, gaits=_SINE, nullable=True)
    adapt_frequency: bool | None = _key(None, bool, "the authors' phase-of-peak frequency adaptation "
                                        "(default: on for the authors' port on spined-dog, off elsewhere)",
                                        gaits=_SINE, nullable=True)
    # the spine
    spine: str = _key("impedance", str, "impedance: motor-rendered (eq. 3); passive: an ideal spring-damper "
                      "with the same gains (no actuator work); rigid: joints locked at the equilibrium arch; "
                      "rigid-impedance: the controller at k = 1e4 N/m", choices=SPINE_VARIANTS)
    spine_path: str = _key("direct", str, "node: the spine node on its in-process bus (soft start, limits, "
                           "watchdogs, CyberGear-quantised feedback; `bound --lcm` runs it in another "
                           "process); direct: the same controller called in process with the node's limit "
                           "damping and torque clamp (fastest)", choices=SPINE_PATHS, spines=("impedance",))
    kx: float | None = _key(None, float, "spine stiffness along x", "N/m", lo=0.0, hi=K_MAX[0],
                            spines=_RENDERED, nullable=True)
    kz: float | None = _key(None, float, "spine stiffness along z", "N/m", lo=0.0, hi=K_MAX[1],
                            spines=_RENDERED, nullable=True)
    kth: float | None = _key(None, float, "spine stiffness in pitch theta", "N*m/rad", lo=0.0, hi=K_MAX[2],
                             spines=_RENDERED, nullable=True)
    dx: float | None = _key(None, float, "spine damping along x", "N*s/m", lo=0.0, hi=D_MAX[0],
                            spines=_RENDERED, nullable=True)
    dz: float | None = _key(None, float, "spine damping along z", "N*s/m", lo=0.0, hi=D_MAX[1],
                            spines=_RENDERED, nullable=True)
    dth: float | None = _key(None, float, "spine damping in pitch theta", "N*m*s/rad", lo=0.0, hi=D_MAX[2],
                             spines=_RENDERED, nullable=True)
    friction_comp: bool = _key(False, bool, "the controller's Stribeck friction compensation (eq. 4)",
                               spines=_MOTOR)
    schedule: bool | None = _key(None, bool, "the authors' spine schedule: higher damping and x_d 0.273 m "
                                 "until 4 s, then the run's gains at 0.268 m (default: on)", gaits=_SINE,
                                 spines=_RENDERED, nullable=True)
    spine_rate_hz: float | None = _key(None, float, "rate of the motor-rendered spine controller (default: "
                                       "the authors' 200 in gait A, every 1 ms physics step otherwise)", "Hz",
                                       lo=1.0, hi=1000.0, spines=_MOTOR, nullable=True)
    # the torso estimator
    imu_noise: float | None = _key(None, float, "estimator q1 noise, 1 sigma (default: 0.002; 0 in the "
                                   "authors' run on spined-dog)", "rad", lo=0.0, hi=1.0, nullable=True)
    imu_bias: float = _key(0.0, float, "estimator q1 bias", "rad", lo=-math.pi, hi=math.pi)
    imu_delay: int | None = _key(None, int, "estimator delay (default: 1)", "1 ms steps", lo=0, hi=1000,
                                 nullable=True)
    base_motion: str | None = _key(None, str, "what the estimate tells the spine law of the base's linear "
                                   "motion: fixed (nothing: the paper's law, eq. 3), constant-twist "
                                   "(a = w x v of the hind body's true twist: the authors' law's assumption),"
                                   " authors-cvel (the same of MuJoCo's cvel read one step late as the "
                                   "authors' released code feeds it). Default: authors-cvel in the "
                                   "authors' run (sine on spined-dog), fixed elsewhere", choices=BASE_MOTIONS,
                                   nullable=True)

    def __post_init__(self) -> None:
        for f in fields(self):
            object.__setattr__(self, f.name, KEYS[f.name].check(getattr(self, f.name)))
        check_applicable(self)

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> Scenario:
        """A scenario from a mapping of keys (TOML, JSON, a study cell); unknown keys are refused."""
        if not isinstance(data, Mapping):
            raise ScenarioError(None, f"a scenario is a table of keys, got {type(data).__name__}")
        unknown = [k for k in data if k not in KEYS]
        if unknown:
            raise ScenarioError(unknown[0], f"unknown key{did_you_mean(unknown[0])}")
        return cls(**dict(data))

    def to_dict(self, *, skip_none: bool = False) -> dict[str, Any]:
        """Every key in declaration order (None: the robot's and gait's default)."""
        out = {f.name: getattr(self, f.name) for f in fields(self)}
        return {k: v for k, v in out.items() if v is not None} if skip_none else out

    def with_overrides(self, overrides: Mapping[str, Any]) -> Scenario:
        """This scenario with some keys changed (a study cell, command-line options over a file)."""
        unknown = [k for k in overrides if k not in KEYS]
        if unknown:
            raise ScenarioError(unknown[0], f"unknown key{did_you_mean(unknown[0])}")
        return replace(self, **dict(overrides))


def did_you_mean(name: str) -> str:
    near = difflib.get_close_matches(name, list(KEYS), n=1)
    return f" (did you mean {near[0]!r}?)" if near else f"; the keys are {', '.join(KEYS)}"


KEYS: dict[str, Key] = {f.name: Key(f.name, **f.metadata["key"]) for f in fields(Scenario)}
DEFAULTS: dict[str, Any] = {f.name: f.default for f in fields(Scenario)}


def check_applicable(s: Scenario) -> None:
    """Refuse a key set away from its default where it cannot act: another gait's parameter, gains on a
    spine that does not use them, two keys that set one thing."""
    for name, key in KEYS.items():
        value = getattr(s, name)
        if value == DEFAULTS[name] or (value is None):
            continue
        if s.gait not in key.gaits:
            raise ScenarioError(name, f"acts only with gait {' or '.join(key.gaits)}, not gait {s.gait!r}")
        if s.spine not in key.spines:
            raise ScenarioError(name, f"acts only with spine {' or '.join(key.spines)}, not spine "
                                      f"{s.spine!r} (its gains and controller are fixed by the variant)")
    if s.host_file is not None:
        if s.host != DEFAULTS["host"]:
            raise ScenarioError("host_file", f"names the host itself: leave host out (got host {s.host!r})")
        if not s.host_file.endswith(".toml"):
            raise ScenarioError("host_file", f"expected a host.toml path, got {s.host_file!r}")
    if s.gait == "authors-raibert" and (s.host != spined_dog.HOST or s.host_file is not None):
        raise ScenarioError("gait", "authors-raibert is the SPARC authors' controller for their spined dog "
                                    "(its legs, frames and gains): use host spined-dog")
    if s.speed is not None and s.stride is not None:
        raise ScenarioError("stride", "sets the target speed (stride x frequency): give speed or stride, "
                                      "not both")
    if s.direction is not None and s.direction not in (1.0, -1.0):
        raise ScenarioError("direction", f"must be +1 or -1, got {s.direction!r}")
    if s.direction is not None and s.variant == "authors":
        raise ScenarioError("direction", "acts only in the literal port (variant literal)")
