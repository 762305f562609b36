"""Every bound metric once: name, unit, plot label, definition and a pure function of the logged series.

Joint power P_j = tau_j * dq_j (W) for the 12 leg joints and the 3 spine joints. With m the robot's mass,
g gravity (the run's `WorldConfig.gravity_m_s2`) and d the distance along the ground over a window:

- CoT_pos  = integral of sum_j max(P_j, 0) / (m g d): actuators pay for positive work (the headline);
- CoT_abs  = integral of sum_j |P_j| / (m g d): negative work also paid;
- CoT_net  = integral of sum_j P_j / (m g d): perfect regeneration (can be negative);
- CoT_elec = integral of sum_j max(P_j + c_j tau_j^2, 0) / (m g d): winding (I^2 R) loss added, c_j from
  the actuator's torque constant and resistance (`spine_module.params.WindingLoss`).

Each split legs / spine / total. A spine that is not an actuator (passive spring, locked joint) costs 0;
its own work is still reported (`spine_work_j`, the passivity check).

Kinds: "block" metrics are defined on any window (the steady window and each stride); "stride" metrics on
a stride (the run's value is their mean over the window's strides); "run" metrics on the steady window
only. Strides start where the gait clock wraps.
"""

from __future__ import annotations

import itertools
import math
import warnings
from collections.abc import Callable, Mapping
from dataclasses import dataclass

import numpy as np

from sparc_quad.sim.bound_log import COLUMNS, DERIVED, LEG_JOINTS, LEGS
from spine_module import params as P

GROUPS = ("legs", "spine", "total")
COTS = ("pos", "abs", "net", "elec")
# CoT_elec's sensitivity to the actuator constants: the winding loss coefficient c_j times these
ELEC_SENSITIVITY = {"elec05": 0.5, "elec2": 2.0}
COT_NAMES = {"pos": "positive work", "abs": "|tau dq|", "net": "perfect regeneration",
             "elec": "with winding losses",
             **{k: f"with winding losses x {v:g}" for k, v in ELEC_SENSITIVITY.items()}}
SPINE_JOINTS = ("q2", "q3", "q4")
# a torque counts as saturated within this fraction of its limit (the clamp returns the limit exactly)
SATURATION_REL_TOL = 1e-6
MIN_DISTANCE_M = 1e-3  # a CoT over less than this is undefined (NaN)


@dataclass(frozen=True)
class Context:
    """What the metrics need besides the series; every constant from the run's params."""

    dt_s: float
    mass_kg: float
    gravity_m_s2: float
    slope_rad: float
    leg_torque_limit_nm: float
    spine_torque_limit_nm: float
    spine_actuated: bool
    # the actuators' winding losses (CoT_elec); None: not known for this robot, CoT_elec is not defined (NaN)
    leg_winding: P.WindingLoss | None = P.SOLO12_WINDING
    spine_winding: P.WindingLoss | None = P.CYBERGEAR_WINDING


@dataclass(frozen=True)
class Metric:
    name: str
    unit: str
    label: str  # for plots and tables
    definition: str
    kind: str  # block | stride | run
    fn: Callable


TABLE: dict[str, Metric] = {}


def _metric(name: str, unit: str, label: str, definition: str, kind: str = "block"):
    def add(fn: Callable) -> Callable:
        if name in TABLE:
            raise ValueError(f"metric {name!r} defined twice")
        TABLE[name] = Metric(name, unit, label, definition, kind, fn)
        return fn
    return add


def label(name: str) -> str:
    """The plot label of a metric, with its unit."""
    m = TABLE.get(name)
    if m is None:
        return name
    return f"{m.label} ({m.unit})" if m.unit not in ("1", "") else m.label


def saturated(tau: np.ndarray, limit_nm: float) -> np.ndarray:
    """|tau| at its limit (elementwise)."""
    return np.abs(tau) >= limit_nm * (1.0 - SATURATION_REL_TOL)


def cost_of_transport(energy_j: float, mass_kg: float, distance_m: float, g_m_s2: float) -> float:
    """energy / (m g d) over the net forward distance d; NaN (no cost of transport) when the robot went
    less than MIN_DISTANCE_M forward, backwards included: |d| made a stride of -0.019 m cost 11.6 and a
    robot walking backwards look efficient."""
    return energy_j / (mass_kg * g_m_s2 * distance_m) if distance_m > MIN_DISTANCE_M else math.nan


def power_terms(tau: np.ndarray, dq: np.ndarray, loss_w_per_nm2: float) -> dict[str, np.ndarray]:
    """Per-sample power summed over the joints (columns), W: pos, abs, net, elec (and elec with the loss
    coefficient scaled by ELEC_SENSITIVITY)."""
    p = tau * dq
    t2 = tau * tau
    out = {
        "pos": np.clip(p, 0.0, None).sum(axis=1),
        "abs": np.abs(p).sum(axis=1),
        "net": p.sum(axis=1),
        "elec": np.clip(p + loss_w_per_nm2 * t2, 0.0, None).sum(axis=1),
    }
    for name, scale in ELEC_SENSITIVITY.items():
        out[name] = np.clip(p + scale * loss_w_per_nm2 * t2, 0.0, None).sum(axis=1)
    return out


def stride_starts(phase_cycles: np.ndarray) -> np.ndarray:
    """Indices where the gait clock (cycles in [0, 1)) wraps: each is the first sample of a stride."""
    return np.flatnonzero(np.diff(phase_cycles) < -0.5) + 1


def touchdowns(contact: np.ndarray) -> np.ndarray:
    """Indices where a foot's contact flag goes from off to on."""
    c = contact > 0.5
    return np.flatnonzero(c[1:] & ~c[:-1]) + 1


def amplitude(x: np.ndarray) -> float:
    """Half the 2.5-97.5 percentile range (robust half peak-to-peak)."""
    if len(x) == 0:
        return math.nan
    lo, hi = np.percentile(x, [2.5, 97.5])
    return float(0.5 * (hi - lo))


def dominant_frequency_hz(x: np.ndarray, dt: float) -> float:
    """The largest peak of x's spectrum (mean removed, Hann window); NaN if flat (ptp < 1e-5)."""
    if len(x) < 16 or float(np.ptp(x)) < 1e-5:  # a locked joint jitters by ~1e-6
        return math.nan
    y = (x - x.mean()) * np.hanning(len(x))
    spec = np.abs(np.fft.rfft(y))
    spec[0] = 0.0
    return float(np.fft.rfftfreq(len(x), dt)[int(np.argmax(spec))])


_IDX = {name: k for k, name in enumerate(COLUMNS)}
_LEG_TAU = [_IDX[f"tau_{j}"] for j in LEG_JOINTS]
_LEG_DQ = [_IDX[f"dq_{j}"] for j in LEG_JOINTS]
_SPINE_TAU = [_IDX[f"tau{j[1:]}"] for j in SPINE_JOINTS]
_SPINE_DQ = [_IDX[f"d{j}"] for j in SPINE_JOINTS]
_CONTACT = [_IDX[f"contact_{leg}"] for leg in LEGS]


_LEG_P, _SPINE_P, _LEG_M = (_IDX[c] for c in DERIVED)
_LEG_HFE_KFE = [_IDX[f"tau_{leg}_{j}"] for leg in LEGS for j in ("hfe", "kfe")]


def _loss(winding: P.WindingLoss | None) -> float:
    """W/(N*m)^2 of an actuator's winding loss; NaN when not known (its CoT_elec is then NaN)."""
    return math.nan if winding is None else winding.loss_w_per_nm2


def derived_columns(s: np.ndarray) -> None:
    """Fill the log's leg_power_w, spine_power_w (sum of |tau dq|, W) and leg_tau_max (max |tau| of HFE and
    KFE, N*m) from its torque and rate columns, in place."""
    s[:, _LEG_P] = power_terms(s[:, _LEG_TAU], s[:, _LEG_DQ], 0.0)["abs"]
    s[:, _SPINE_P] = power_terms(s[:, _SPINE_TAU], s[:, _SPINE_DQ], 0.0)["abs"]
    s[:, _LEG_M] = np.abs(s[:, _LEG_HFE_KFE]).max(axis=1) if len(s) else 0.0


class Series:
    """A run's log with its per-sample powers, computed once for every window cut from it."""

    def __init__(self, s: np.ndarray, ctx: Context):
        self.s, self.ctx = s, ctx
        self.tau_legs, self.dq_legs = s[:, _LEG_TAU], s[:, _LEG_DQ]
        self.tau_spine, self.dq_spine = s[:, _SPINE_TAU], s[:, _SPINE_DQ]
        legs = power_terms(self.tau_legs, self.dq_legs, _loss(ctx.leg_winding))
        spine = power_terms(self.tau_spine, self.dq_spine, _loss(ctx.spine_winding))
        self.spine_abs_w = spine["abs"]  # what the joints do, actuator or not
        if not ctx.spine_actuated:
            spine = {c: np.zeros(len(s)) for c in spine}
        self.power = {"legs": legs, "spine": spine}
        self.spine_net_w = (self.tau_spine * self.dq_spine).sum(axis=1)  # actuator or not
        self.x_along = s[:, _IDX["x"]] / math.cos(ctx.slope_rad)
        self.contacts = s[:, _CONTACT] > 0.5

    def col(self, name: str) -> np.ndarray:
        return self.s[:, _IDX[name]]


@dataclass
class Window:
    """Samples [a, b) of a series; `strides` the (start, end) sample pairs of its complete strides."""

    series: Series
    a: int
    b: int
    strides: tuple[tuple[int, int], ...] = ()

    @property
    def ctx(self) -> Context:
        return self.series.ctx

    def col(self, name: str) -> np.ndarray:
        return self.series.col(name)[self.a:self.b]

    def energy_j(self, cot: str, group: str) -> float:
        p = self.series.power
        if group == "total":
            return self.energy_j(cot, "legs") + self.energy_j(cot, "spine")
        return float(p[group][cot][self.a:self.b].sum() * self.ctx.dt_s)


def _span(w: Window) -> float:
    return (w.b - w.a) * w.ctx.dt_s


def _distance(w: Window) -> float:
    x = w.series.x_along
    return float(x[w.b - 1] - x[w.a]) if w.b - w.a > 1 else 0.0


_metric("span_s", "s", "window length", "time the window spans (a stride: its period)")(_span)
_metric("distance_m", "m", "distance", "x travelled along the ground (x / cos slope), last minus first "
        "sample")(_distance)


@_metric("speed_m_s", "m/s", "mean speed", "distance / span")
def _speed(w: Window) -> float:
    span = _span(w)
    return _distance(w) / span if span > 0 else math.nan


def _add_cot(c: str, g: str) -> None:
    part = {"legs": "legs only", "spine": "spine only", "total": "legs + spine"}[g]

    def cot(w: Window) -> float:
        return cost_of_transport(w.energy_j(c, g), w.ctx.mass_kg, _distance(w), w.ctx.gravity_m_s2)

    def power(w: Window) -> float:
        span = _span(w)
        return w.energy_j(c, g) / span if span > 0 else math.nan

    _metric(f"cot_{c}_{g}", "1", f"CoT_{c} {part}", f"cost of transport, {COT_NAMES[c]}, {part}: "
            f"energy / (m g d)")(cot)
    _metric(f"power_{c}_{g}_w", "W", f"mean power ({c}) {part}", f"energy ({COT_NAMES[c]}, {part}) / "
            "span")(power)


for _c in COTS:
    for _g in GROUPS:
        _add_cot(_c, _g)
for _c in ELEC_SENSITIVITY:
    _add_cot(_c, "total")


@_metric("spine_work_j", "J", "spine work", "integral of sum over q2..q4 of tau dq (the spine torque's work "
         "on the joints, actuator or not)")
def _spine_work(w: Window) -> float:
    return float(w.series.spine_net_w[w.a:w.b].sum() * w.ctx.dt_s)


@_metric("spine_work_plus_spring_energy_change_j", "J", "spine work + spring energy change",
         "spine_work_j + the passive spring's stored energy change over the window: <= 0 for a passive "
         "element")
def _passivity(w: Window) -> float:
    if w.b - w.a < 2:
        return math.nan
    e = w.series.col("spine_spring_energy_j")
    return _spine_work(w) + float(e[w.b - 1] - e[w.a])


def _add_duty(name: str, legs: slice, what: str) -> None:
    def duty(w: Window) -> float:
        c = w.series.contacts[w.a:w.b, legs]
        return float(c.mean()) if c.size else math.nan

    _metric(f"duty_{name}", "1", f"duty factor {what}",
            f"fraction of samples with the foot in contact, {what}")(duty)


_add_duty("mean", slice(0, 4), "mean of the 4 feet")
_add_duty("hind", slice(0, 2), "hind feet")
_add_duty("front", slice(2, 4), "front feet")
for _k, _leg in enumerate(LEGS):
    _add_duty(_leg, slice(_k, _k + 1), f"foot {_leg}")


@_metric("flight_fraction", "1", "flight fraction", "fraction of samples with no foot in contact")
def _flight_fraction(w: Window) -> float:
    c = w.series.contacts[w.a:w.b]
    return float((~c.any(axis=1)).mean()) if len(c) else math.nan


@_metric("flight_time_s", "s", "flight time per stride", "time with no foot in contact in a stride",
         kind="stride")
def _flight_time(w: Window) -> float:
    return float((~w.series.contacts[w.a:w.b].any(axis=1)).sum() * w.ctx.dt_s)


@_metric("stride_frequency_hz", "Hz", "stride frequency", "1 / stride period (gait-clock strides)",
         kind="stride")
def _stride_frequency(w: Window) -> float:
    return 1.0 / _span(w)


_metric("stride_length_m", "m", "stride length", "distance over a stride", kind="stride")(_distance)
_metric("spine_work_per_stride_j", "J", "spine work per stride", "spine_work_j over a stride",
        kind="stride")(_spine_work)


def _add_amplitude(name: str, column: str, unit: str, what: str) -> None:
    _metric(name, unit, f"{what} amplitude", f"half the 2.5-97.5 percentile range of {column}")(
        lambda w: amplitude(w.col(column)))


_add_amplitude("spine_x_amplitude_m", "spine_x", "m", "spine x")
_add_amplitude("spine_z_amplitude_m", "spine_z", "m", "spine z")
_add_amplitude("spine_theta_amplitude_rad", "spine_theta", "rad", "spine theta")
_add_amplitude("pitch_amplitude_hind_rad", "q1_true", "rad", "hind body pitch")
_add_amplitude("pitch_amplitude_front_rad", "pitch_front", "rad", "front body pitch")
_metric("pitch_mean_hind_rad", "rad", "hind body pitch, mean", "mean of q1_true (+ nose down)")(
    lambda w: float(w.col("q1_true").mean()))
_metric("pitch_mean_front_rad", "rad", "front body pitch, mean", "mean of pitch_front (+ nose down)")(
    lambda w: float(w.col("pitch_front").mean()))
for _name, _unit in (("x", "m"), ("z", "m"), ("theta", "rad")):
    _metric(f"spine_{_name}_range_{_unit}", _unit, f"spine {_name} range", f"peak-to-peak of spine_{_name}",
            kind="run")((lambda n: lambda w: float(np.ptp(w.col(f"spine_{n}"))))(_name))


@_metric("n_strides", "1", "complete strides", "gait-clock strides complete inside the window", kind="run")
def _n_strides(w: Window) -> float:
    return float(len(w.strides))


@_metric("commanded_gait_frequency_hz", "Hz", "gait frequency (commanded)", "mean of the gait clock's "
         "frequency column", kind="run")
def _gait_f(w: Window) -> float:
    return float(w.col("gait_frequency_hz").mean())


def _add_dominant(name: str) -> None:
    _metric(f"spine_{name}_dominant_hz", "Hz", f"spine {name} dominant frequency",
            f"largest spectral peak of spine_{name}", kind="run")(
        lambda w: dominant_frequency_hz(w.col(f"spine_{name}"), w.ctx.dt_s))


_add_dominant("x")
_add_dominant("theta")


@_metric("spine_x_dominant_over_gait", "1", "spine x dominant / gait frequency",
         "spine_x_dominant_hz / commanded_gait_frequency_hz", kind="run")
def _dominant_ratio(w: Window) -> float:
    f = _gait_f(w)
    return dominant_frequency_hz(w.col("spine_x"), w.ctx.dt_s) / f if f > 0 else math.nan


@_metric("touchdown_frequency_hz", "Hz", "hind-left touchdowns per second",
         "(n - 1) / (time from first to last off-to-on edge of contact_HL)", kind="run")
def _touchdown_frequency(w: Window) -> float:
    td = touchdowns(w.col("contact_HL"))
    return (len(td) - 1) / ((td[-1] - td[0]) * w.ctx.dt_s) if len(td) >= 2 else math.nan


@_metric("hind_touchdowns_per_stride", "1", "hind-left touchdowns per stride",
         "contact_HL off-to-on edges inside the complete strides / their number", kind="run")
def _touchdowns_per_stride(w: Window) -> float:
    if not w.strides:
        return math.nan
    a, b = w.strides[0][0], w.strides[-1][1]
    return float(len(touchdowns(w.series.col("contact_HL")[a - 1:b]))) / len(w.strides)


@_metric("peak_leg_torque_nm", "N*m", "peak leg torque", "max |tau| over the 12 leg joints", kind="run")
def _peak_leg(w: Window) -> float:
    return float(np.abs(w.series.tau_legs[w.a:w.b]).max())


@_metric("leg_saturation_share", "1", "leg saturation share",
         "fraction of samples with a leg torque at the host's limit", kind="run")
def _leg_sat(w: Window) -> float:
    return float(saturated(w.series.tau_legs[w.a:w.b], w.ctx.leg_torque_limit_nm).any(axis=1).mean())


@_metric("peak_spine_torque_nm", "N*m", "peak spine torque", "max |tau| over q2..q4", kind="run")
def _peak_spine(w: Window) -> float:
    return float(np.abs(w.series.tau_spine[w.a:w.b]).max())


@_metric("spine_torque_rms_nm", "N*m", "spine torque RMS (holding torque)", "RMS of tau over q2..q4 and "
         "samples (for rigid-impedance: the torque that holds the spine)", kind="run")
def _spine_rms(w: Window) -> float:
    return float(np.sqrt((w.series.tau_spine[w.a:w.b] ** 2).mean()))


@_metric("spine_saturation_share", "1", "spine saturation share",
         "fraction of samples with a spine torque at the spine actuator's limit", kind="run")
def _spine_sat(w: Window) -> float:
    return float(saturated(w.series.tau_spine[w.a:w.b], w.ctx.spine_torque_limit_nm).any(axis=1).mean())


@_metric("peak_spine_power_w", "W", "peak spine power", "max over samples of sum over q2..q4 of |tau dq|",
         kind="run")
def _peak_spine_power(w: Window) -> float:
    return float(w.series.spine_abs_w[w.a:w.b].max())


@_metric("lateral_drift_m", "m", "lateral drift", "y change over the window", kind="run")
def _drift(w: Window) -> float:
    y = w.col("y")
    return float(y[-1] - y[0])


BLOCK = tuple(m for m in TABLE.values() if m.kind == "block")
STRIDE = tuple(m for m in TABLE.values() if m.kind == "stride")
RUN = tuple(m for m in TABLE.values() if m.kind == "run")


def empty() -> dict:
    """Every metric NaN: what a run without a steady window reports."""
    return dict.fromkeys(TABLE, math.nan)


def merge_disjoint(a: Mapping, b: Mapping) -> dict:
    """a and b as one dict; a key in both is an error (no metric silently replaces another)."""
    both = sorted(set(a) & set(b))
    if both:
        raise ValueError(f"keys defined twice: {', '.join(both)}")
    return {**a, **b}


def measure(s: np.ndarray, ctx: Context, t_start_s: float) -> dict:
    """Every metric of TABLE over the steady window (samples with t >= t_start_s), plus `window_ok`
    (>= 2 complete strides), `warning` when not, and `strides`: one dict of block + stride metrics each."""
    out: dict = {**empty(), "window_ok": False, "strides": []}
    t = s[:, _IDX["t"]] if len(s) else np.zeros(0)
    w_idx = np.flatnonzero(t >= t_start_s)
    if len(w_idx) < 2:
        return _warn(out, "steady window is empty (0 complete strides): the run ended or fell before its "
                          "start-up was over")
    series = Series(s, ctx)
    a, b = int(w_idx[0]), len(s)
    starts = stride_starts(series.col("gait_phase"))
    starts = starts[starts >= a]
    bounds = tuple((int(x), int(y)) for x, y in itertools.pairwise(starts))
    whole = Window(series, a, b, bounds)
    strides = []
    for sa, sb in bounds:
        sw = Window(series, sa, sb)
        st = {m.name: m.fn(sw) for m in (*BLOCK, *STRIDE)}
        st["t_start_s"] = float(t[sa])
        strides.append(st)
    out.update({m.name: m.fn(whole) for m in (*BLOCK, *RUN)})
    for m in STRIDE:
        out[m.name] = float(np.mean([st[m.name] for st in strides])) if strides else math.nan
    out["strides"] = strides
    out["window_ok"] = len(strides) >= 2
    if not out["window_ok"]:
        _warn(out, f"steady window {_span(whole):.2f} s holds {len(strides)} complete strides (< 2): gait "
                   "metrics are not meaningful; run longer")
    return out


def _warn(out: dict, msg: str) -> dict:
    out["warning"] = msg
    warnings.warn(msg, RuntimeWarning, stacklevel=3)
    return out
