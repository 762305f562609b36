"""What every effect kind provides: its parameters, its forward model, and how the gap workflow finds it.

An effect kind is a class (never instantiated) whose class attributes and classmethods answer every
question the library asks about that effect; `sparc_quad.effects` keeps them by name. The defaults here
describe the common case, a per-joint effect linear in one amplitude `AMPLITUDE`; a kind overrides what
differs. Arguments named `lib`, `sel`, `search` are the gap workflow's column library, fitter and search
(`sparc_quad.gap.regressors.Library`, `.fitting.Selector`, `.select.Search`), passed in so that this package
imports nothing above it (the simulator uses the forward model too).

Forward model (what a simulation applies; the plant adds up the kinds' contributions, see plant.py):
    build(entries, n) -> state            once per plant, from [(joint index, params, entry), ...]
    encoder_offset_rad, delay_s, armature_kg_m2, coupled_mass: per-joint (or n x n) arrays, summed
    actuate(state, tau): one stage of the actuator chain, applied in the order of `STAGE`
    friction_law(state, law): add to the joint friction law's terms (`FrictionLaw`)
    friction(state, law, torque, slope) -> (torque, slope) with the kind's own friction added (called
        once per entry, in the plant file's order, with the state `build` makes of that entry alone)
    apply_to_model(state, model): a pinocchio model with the kind's inertial changes
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np

from sparc_quad.effects.registry import PlantEffectsError, kind


@dataclass(frozen=True)
class Param:
    """One parameter of an effect: its key in the plant file (SI), unit, meaning, default if optional."""

    key: str
    unit: str
    doc: str
    default: Any = None


class EffectKind:
    NAME: ClassVar[str] = ""
    DOC: ClassVar[str] = ""  # one line: what it does to the plant
    PARAMS: ClassVar[tuple[Param, ...]] = ()
    AMPLITUDE: ClassVar[str | None] = None  # the parameter that is the fitted linear amplitude
    SYNTH_DEFAULTS: ClassVar[dict] = {}  # `gap synth` sizes a CyberGear-class joint could plausibly show
    SYNTH_ONLY: ClassVar[tuple[str, ...]] = ()  # synth-only keys resolved by `resolve_synth`
    STAGE: ClassVar[int | None] = None  # position in the actuator chain (delay is first, then these)
    # ---- the search's view -----------------------------------------------------------------------------
    FIXED: ClassVar[bool] = False  # a nonlinear map of the command (no linear amplitude), shape profiled
    ON_COMMAND: ClassVar[bool] = False  # acts on the commanded torque: no candidate when it is measured
    EXPECTED: ClassVar[bool] = False  # member of the physically expected group (tried together per joint)
    SINGLE: ClassVar[bool] = True  # tried alone on every actuated joint at each forward step
    ACTS_ON: ClassVar[str] = "joint"  # residual it changes: "joint" its own, "all" every joint, "direction"
    REFINES: ClassVar[str | None] = None  # only meaningful next to this effect on the same joint

    # ---- plant file -----------------------------------------------------------------------------------
    @classmethod
    def complete(cls, params: dict) -> dict:
        """Params of a plant-file entry with defaults filled in; raises on a missing one."""
        out = dict(params)
        for p in cls.PARAMS:
            if p.key not in out:
                if p.default is None:
                    raise PlantEffectsError(f"effect {cls.NAME}: missing parameter {p.key!r}")
                out[p.key] = list(p.default) if isinstance(p.default, list | tuple) else p.default
        return out

    @classmethod
    def param_keys(cls) -> tuple[str, ...]:
        return tuple(p.key for p in cls.PARAMS)

    # ---- forward model --------------------------------------------------------------------------------
    @classmethod
    def build(cls, entries: list[tuple[int, dict, Any]], n: int) -> Any:
        """Default state: the sum per joint of the amplitude (else the first) parameter, (n,)."""
        key = cls.AMPLITUDE or cls.PARAMS[0].key
        out = np.zeros(n)
        for j, p, _e in entries:
            out[j] += p[key]
        return out

    @classmethod
    def encoder_offset_rad(cls, state) -> np.ndarray | None:
        return None

    @classmethod
    def delay_s(cls, state) -> np.ndarray | None:
        return None

    @classmethod
    def armature_kg_m2(cls, state) -> np.ndarray | None:
        return None

    @classmethod
    def coupled_mass(cls, state) -> np.ndarray | None:
        return None

    @classmethod
    def actuate(cls, state, tau: np.ndarray) -> np.ndarray:
        return tau

    @classmethod
    def friction_law(cls, state, law: FrictionLaw) -> None:
        """Add to the terms of the joint friction law (Coulomb level, viscous, direction-dependent)."""

    @classmethod
    def friction(cls, state, law: FrictionLaw, torque: np.ndarray,
                 slope: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(torque, -d torque / d dq diagonal) with a friction outside the law added (after the law's)."""
        return torque, slope

    @classmethod
    def apply_to_model(cls, state, model, joints: list[str]):
        return model

    @classmethod
    def has_own_friction(cls) -> bool:
        return cls.friction.__func__ is not EffectKind.friction.__func__

    @classmethod
    def changes_model(cls) -> bool:
        """Whether the kind changes the rigid bodies (not only the actuators, friction or armature)."""
        return cls.apply_to_model.__func__ is not EffectKind.apply_to_model.__func__

    # ---- identification -------------------------------------------------------------------------------
    @classmethod
    def n_params(cls, term) -> int:
        return (0 if cls.FIXED else 1) + (1 if term.theta is not None else 0)

    @classmethod
    def key(cls, term) -> tuple:
        return (cls.NAME, term.joint)

    @classmethod
    def column(cls, lib, term, bi: int) -> np.ndarray:
        """(n_dec, nv) residual column of block bi for amplitude 1 (or the fixed map); default: the kind's
        `signal` on the term's joint, zero on the others."""
        ja = lib.robot.actuated.index(term.joint)
        return joint_put(lib.blocks[bi], lib.robot.nv, lib.joint_v(term.joint), cls.signal(lib, term, bi, ja))

    @classmethod
    def signal(cls, lib, term, bi: int, ja: int) -> np.ndarray:
        """(n_dec,) residual of amplitude 1 on actuated joint ja (velocity index lib.joint_v) of block bi."""
        raise NotImplementedError(cls.NAME)

    @classmethod
    def grid(cls, sel, joint: str) -> list[float] | None:
        """Values of the shape parameter theta to profile; None: the kind has none."""
        return None

    @classmethod
    def candidate(cls, sel, selected: list, joint: str):
        """(term, fit) of the best version of this effect on `joint` next to `selected`."""
        return sel.profile(selected, cls.NAME, joint, cls.grid(sel, joint))

    @classmethod
    def joint_options(cls, search, selected: list, taken: set, joint: str) -> list[list[Term]]:
        """Term sets on `joint` tried after its expected group (e.g. a refinement of a selected effect)."""
        return []

    @classmethod
    def options(cls, search, selected: list, taken: set) -> list[list[Term]]:
        """Term sets tried after every joint's own (e.g. a body's base parameters, a coupled motor)."""
        return []

    @classmethod
    def params(cls, term) -> tuple[dict, dict]:
        """(params SI, standard errors) of a fitted term."""
        return {cls.AMPLITUDE: term.coef}, {cls.AMPLITUDE: term.se}

    @classmethod
    def plausible(cls, p: dict, scale, total_mass_kg: float) -> str | None:
        """None when the fitted parameters are physically possible for this robot, else why not.
        `scale`: the joint's `select.JointScale` (torque range, RMS velocity and acceleration)."""
        return None

    @classmethod
    def model_problem(cls, search, fit) -> str | None:
        """Why the joint fit `fit` (terms of several kinds) is impossible because of this kind, or None."""
        return None

    # ---- synthetic data -------------------------------------------------------------------------------
    @classmethod
    def synth_params(cls, given: dict, robot, joint: str) -> tuple[dict, str | None]:
        """(params, link) of a hidden effect for `gap synth`: defaults under the given values."""
        return {**cls.SYNTH_DEFAULTS, **given}, None

    @classmethod
    def resolve_synth(cls, params: dict, joint_index: int, nominal_peak_nm) -> None:
        """Replace synth-only keys in place; nominal_peak_nm(j): peak |tau_cmd| of joint j, nominal plant."""

    # ---- report ---------------------------------------------------------------------------------------
    @classmethod
    def format_params(cls, params: dict) -> str:
        return ", ".join(f"{k}={format_value(v)}" for k, v in params.items())


@dataclass
class FrictionLaw:
    """Joint friction as eq. (4) writes it, per joint at velocity dq with th = tanh(dq / eps):

        torque = -(level th + linear dq + even |th|)

    `level` may depend on dq (Stribeck), `dlevel` is its derivative; the kinds add to the terms."""

    dq: np.ndarray
    th: np.ndarray
    eps: float
    level: np.ndarray = None
    dlevel: np.ndarray = None
    linear: np.ndarray = None
    even: np.ndarray = None

    def __post_init__(self):
        for name in ("level", "dlevel", "linear", "even"):
            setattr(self, name, np.zeros_like(self.dq))

    def torque_and_slope(self) -> tuple[np.ndarray, np.ndarray]:
        th = self.th
        torque = -(self.level * th + self.linear * self.dq + self.even * np.abs(th))
        slope = (self.dlevel * th + (self.level + self.even * np.sign(th)) * (1.0 - th**2) / self.eps
                 + self.linear)
        return torque, slope


@dataclass(eq=False)
class Term:
    """One candidate or fitted effect in the gap search: fixed shape parameter `theta`, fitted amplitude."""

    name: str
    joint: str
    theta: float | None = None
    link: str | None = None
    xyz: np.ndarray | None = None  # payload_mass: point on the link
    direction: np.ndarray | None = None  # coupled_*: the motor's coordinate s = direction . q_actuated
    param_index: int | None = None  # link_inertia: standard-parameter column (10 (body - 1) + k)
    combination: str = ""  # link_inertia: the identifiable combination it stands for
    coef_index: int = -1  # index of its amplitude in the joint fit
    coef: float = float("nan")
    se: float = float("nan")
    theta_se: float = float("nan")

    @property
    def kind(self) -> type[EffectKind]:
        return kind(self.name)

    @property
    def key(self) -> tuple:
        return self.kind.key(self)

    @property
    def fixed(self) -> bool:
        return self.kind.FIXED

    @property
    def n_params(self) -> int:
        return self.kind.n_params(self)

    def params(self) -> tuple[dict, dict]:
        """(params SI, standard errors)."""
        return self.kind.params(self)

    def effect(self) -> Effect:
        """The plant-file entry of the fitted term."""
        return Effect(self.name, self.joint, self.params()[0], self.link)


@dataclass
class Effect:
    """One entry of a plant file: a kind by name, the joint it is listed with, its parameters (SI)."""

    name: str
    joint: str | None
    params: dict
    link: str | None = None  # the link a payload or link error sits on
    extra: dict = field(default_factory=dict)  # free-form annotations (e.g. "ambiguous_with")

    def to_dict(self) -> dict:
        d = {"name": self.name, "joint": self.joint, "params": dict(self.params)}
        if self.link is not None:
            d["link"] = self.link
        d.update(self.extra)
        return d

    @staticmethod
    def from_dict(d: dict) -> Effect:
        name = d.get("name")
        k = kind(name)
        extra = {key: v for key, v in d.items() if key not in ("name", "joint", "params", "link")}
        return Effect(name, d.get("joint"), k.complete(d.get("params", {})), d.get("link"), extra)


def format_value(v) -> str:
    """A parameter value for report.md: numbers to 4 significant digits, lists element-wise, text as is."""
    if isinstance(v, bool) or v is None:
        return str(v)
    if isinstance(v, int | float | np.floating | np.integer):
        return f"{v:.4g}"
    if isinstance(v, list | tuple | np.ndarray):
        return "[" + ", ".join(format_value(x) for x in v) + "]"
    return str(v)


def positive_below(value: float, bound: float, what: str, unit: str = "") -> str | None:
    """None when 0 < value < bound, else the plausibility message naming the range."""
    if 0 < value < bound:
        return None
    return f"{what} must be in (0, {bound:.3g})" + (f" {unit}" if unit else "")


def inertia_max(sc) -> float:
    """Largest plausible inertia on a joint (kg*m^2): its torque range over its RMS acceleration."""
    return sc.tau_range / max(sc.ddq_rms, 1e-3)


def viscous_max(sc) -> float:
    """Largest plausible viscous coefficient (N*m*s/rad): torque range over RMS velocity."""
    return sc.tau_range / max(sc.dq_rms, 1e-3)


def joint_put(b, nv: int, v: int, col_act: np.ndarray) -> np.ndarray:
    """An (n_dec, nv) column that is `col_act` on velocity index v and zero elsewhere."""
    out = np.zeros((b.n, nv))
    out[:, v] = col_act
    return out


def smoothed_sign(b, ja: int, eps: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(dq, tanh(dq/eps), its derivative, half step of dq) of actuated joint ja at full rate: friction over
    a step is f(dq_k) + f'(dq_k) (dq_k+1 - dq_k) / 2, as `Robot.forward_step` integrates it."""
    dq = b.dq_act_raw[:, ja]
    th = np.tanh(dq / eps)
    return dq, th, (1.0 - th**2) / eps, b.half_step_dq[:, ja]
