"""Shared helpers for the gap workflow tests (not a test module)."""

from __future__ import annotations

from pathlib import Path

from sparc_quad.gap.synth import synth
from sparc_quad.gap.workflow import run

# One joint per effect where the spine's bench excitation makes it identifiable (q3 carries a mid-size
# inertia and its commanded torque crosses zero; see docs/gap.md).
EFFECT_CASES = {
    "coulomb_friction": "coulomb_friction:joint=q3",
    "viscous_friction": "viscous_friction:joint=q2",
    "stribeck_friction": "stribeck_friction:joint=q3",
    "rotor_inertia": "rotor_inertia:joint=q3",
    "torque_gain": "torque_gain:joint=q2",
    "torque_offset": "torque_offset:joint=q3",
    "time_delay": "time_delay:joint=q3",
    "payload_mass": "payload_mass:joint=q3",
    "encoder_offset": "encoder_offset:joint=q2",
    "torque_saturation": "torque_saturation:joint=q3",
    "torque_deadband": "torque_deadband:joint=q3",
}


def run_case(tmp: Path, effects, seed: int, plots: bool = False, **synth_kw) -> tuple[dict, list]:
    kw = {"n_trials": 3, "periods": 4, "period_s": 1.5, "amp_rad": 0.4}
    kw.update(synth_kw)
    res = synth(tmp / "trials", effects, seed=seed, **kw)
    rep = run(res["trials"], tmp / "out", plots=plots)
    return rep, res["hidden"]


def param_errors(found: dict, hidden) -> list[str]:
    """Messages for hidden parameters not recovered within 10 % or 2 standard errors."""
    bad = []
    for k, v in hidden.params.items():
        if k == "xyz_m":
            continue
        est, se = found["params"][k], found["std_err"].get(k, 0.0)
        if not (abs(est - v) <= 0.10 * abs(v) or abs(est - v) <= 2 * se):
            bad.append(f"{hidden.name}.{k}: {est:.5g} vs {v:.5g} (se {se:.2g})")
    return bad


def check_named(rep: dict, hidden) -> list[str]:
    """Every hidden effect named on its joint with its parameters; the gap closed on held-out data."""
    errs = []
    for h in hidden:
        match = [e for e in rep["effects"] if e["name"] == h.name and e["joint"] == h.joint]
        if not match:
            named = [(e["name"], e["joint"]) for e in rep["effects"]]
            errs.append(f"{h.name}@{h.joint} not named; named {named}"
                        f" ambiguous {[(a['best']['name'], a['alternatives']) for a in rep['ambiguous']]}")
            continue
        errs += param_errors(match[0], h)
    extra = [e for e in rep["effects"] if (e["name"], e["joint"]) not in {(h.name, h.joint) for h in hidden}]
    if extra:
        errs.append(f"extra effects named: {[(e['name'], e['joint'], e['params']) for e in extra]}")
    for j, ratio in rep["gap_after_over_floor"].items():
        if ratio > 1.1:
            errs.append(f"held-out gap on {j} is {ratio:.3f}x the noise floor")
    if rep["verdict"] != "gap_closed":
        errs.append(f"verdict {rep['verdict']}")
    return errs
