"""A torque limit hidden on any joint of an arm `gap synth` can simulate, at 50-95 % of that joint's peak
demanded torque, is named as `torque_saturation` on that joint with its limit within 10 %, and never as a
torque offset or a deadband.

The arms: the bench spine (q2, q3, q4, as `sparc-quad gap synth` makes it: its defaults, ±0.3 rad) and a
two-link chain with a fixed mount (shoulder, elbow; another URDF, no nominal friction). The limit is
`limit_fraction` x the joint's peak |commanded torque| in a run of the nominal plant (`gap synth`'s own
sizing). Under feedback the controller winds up against a low limit: the command then exceeds it on most
samples or all (a limit at half q2's peak demand holds the chain only part-way, and the command sits at
the URDF's effort clamp), while a limit at 95 % of a light joint's peak is reached on a few percent of the
samples of one trial. Before the fix, 4 of these 15 cases were named right (the rest as offsets, deadbands,
asymmetric Coulomb levels or link-inertia changes).

Default suite: three cases, one per limit, on three joints of both arms (the wound-up q2, the light q4 at
95 %, the chain's elbow). Slow suite: every joint of both arms x 50/70/95 % x two seeds."""

from __future__ import annotations

from pathlib import Path

import pytest

from sparc_quad.effects import PlantEffects
from sparc_quad.gap.synth import synth
from sparc_quad.gap.workflow import run
from tests.integration.gap.test_gap_workflow import CHAIN

ARMS = {"spine": ("q2", "q3", "q4"), "chain2": ("shoulder", "elbow")}
FRACTIONS = (0.5, 0.7, 0.95)
SURROGATES = {"torque_offset", "torque_deadband"}


def arm_kwargs(arm: str, tmp: Path) -> dict:
    """synth() keywords of an arm: the spine as `gap synth` makes it, else the two-link chain."""
    if arm == "spine":
        return {}
    urdf = tmp / "chain2.urdf"
    urdf.write_text(CHAIN)
    act = list(ARMS[arm])
    return {"urdf": urdf, "actuated": act, "fixed": {"mount": 0.3}, "nominal": PlantEffects(act)}


def saturation_errors(tmp: Path, arm: str, joint: str, fraction: float, seed: int) -> list[str]:
    tmp.mkdir(parents=True, exist_ok=True)
    res = synth(tmp / "trials", [f"torque_saturation:joint={joint},limit_fraction={fraction}"], seed=seed,
                n_trials=3, periods=4, period_s=1.5, amp_rad=0.3, **arm_kwargs(arm, tmp))
    limit = res["hidden"][0].params["limit_nm"]
    rep = run(res["trials"], tmp / "out", plots=False)
    named = [(e["name"], e["joint"], e["params"]) for e in rep["effects"]]
    errs = []
    found = [p["limit_nm"] for n, j, p in named if (n, j) == ("torque_saturation", joint)]
    if not found:
        errs.append(f"torque_saturation@{joint} not named")
    elif abs(found[0] - limit) > 0.10 * limit:
        errs.append(f"limit {found[0]:.4g} N*m, hidden {limit:.4g} N*m")
    wrong = [(n, j) for n, j, _ in named if n in SURROGATES]
    wrong += [(a["name"], a["joint"]) for amb in rep["ambiguous"] for a in amb["alternatives"]
              if a["name"] in SURROGATES]
    if wrong:
        errs.append(f"surrogates named: {wrong}")
    return [f"{arm} {joint} {fraction:.0%} seed {seed}: {e}; named {[(n, j) for n, j, _ in named]}"
            for e in errs]


@pytest.mark.parametrize(("arm", "joint", "fraction"), [("spine", "q2", 0.5), ("spine", "q4", 0.95),
                                                        ("chain2", "elbow", 0.7)])
def test_saturation_named(tmp_path, arm, joint, fraction):
    errs = saturation_errors(tmp_path, arm, joint, fraction, seed=0)
    assert not errs, errs


@pytest.mark.slow
def test_saturation_every_joint_and_limit(tmp_path):
    cases = [(arm, j, f, s) for arm, joints in ARMS.items() for j in joints for f in FRACTIONS
             for s in (0, 1)]
    errs = []
    for arm, j, f, s in cases:
        errs += saturation_errors(tmp_path / f"{arm}_{j}_{f}_{s}", arm, j, f, s)
    print(f"\nsaturation: {len(cases) - len(errs)}/{len(cases)} named right")
    assert not errs, errs
