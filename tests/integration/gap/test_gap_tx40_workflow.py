"""The gap workflow on the real Stäubli TX40 log (tests/data/staubli_tx40), end to end:
runs to the end with the URDF as published (its last link is massless), names friction on the main joints
and no actuator-on-command effect (the torques are measured), the held-out inverse-dynamics residual on
joints 1-4 is at least 75 % below the nominal model's and within 1.5x of the physically expected fit
(Coulomb + viscous + rotor inertia on every joint); the coupled wrist (joints 5, 6) ends
`unexplained_residual` unless the coupling effect is named.

Default suite: the two committed 1 kHz windows (train on one, hold out the other). Slow: the whole
45 000-sample 5 kHz log as recorded (made from the committed source by the importer), one contiguous
held-out block."""

from __future__ import annotations

import pytest

from sparc_quad.gap import import_tx40 as im
from sparc_quad.gap.workflow import run
from tests.paths import DATA as TEST_DATA

DATA = TEST_DATA / "staubli_tx40"
FRICTION = {"coulomb_friction", "viscous_friction", "stribeck_friction"}
MAIN = ("joint_1", "joint_2", "joint_3", "joint_4")


def named(rep: dict) -> set[tuple[str, str]]:
    """(name, joint) of every named effect, the best of an ambiguous set included."""
    out = {(e["name"], e["joint"]) for e in rep["effects"]}
    return out | {(a["best"]["name"], a["best"]["joint"]) for a in rep["ambiguous"]}


def check(rep: dict) -> list[str]:
    errs = []
    eff = named(rep)
    alts = {(x["name"], x["joint"]) for a in rep["ambiguous"] for x in a["alternatives"]}
    if rep["model_checks"]["massless_joints"] != ["joint_6"]:
        errs.append(f"massless joints {rep['model_checks']['massless_joints']}")
    for j in MAIN:
        if not any((n, j) in eff for n in FRICTION):
            errs.append(f"no friction named on {j}")
    bad = {(n, j) for n, j in eff | alts if n in ("torque_saturation", "torque_deadband", "time_delay")}
    if bad:
        errs.append(f"actuator-on-command effects named on measured torque: {bad}")
    before, after = rep["gap_before"]["id_residual_rms_nm"], rep["gap_after"]["id_residual_rms_nm"]
    ref = rep["reference_fit"]["id_residual_rms_nm"]
    for j in MAIN:
        if after[j] > 0.25 * before[j]:
            errs.append(f"{j}: held-out residual {after[j]:.3g} N*m not 75 % below nominal {before[j]:.3g}")
        if after[j] > 1.5 * ref[j]:
            errs.append(f"{j}: held-out residual {after[j]:.3g} N*m above 1.5x the expected fit's "
                        f"{ref[j]:.3g}")
    coupling = any(n.startswith("coupled_") for n, _ in eff)
    if not coupling and rep["verdict"] != "unexplained_residual":
        errs.append(f"coupled wrist without the coupling effect, yet verdict {rep['verdict']}")
    return errs


def summary(rep: dict) -> str:
    b, a = rep["gap_before"]["id_residual_rms_nm"], rep["gap_after"]["id_residual_rms_nm"]
    r = rep["reference_fit"]["id_residual_rms_nm"]
    rows = [f"  {j}: before {b[j]:.3g} after {a[j]:.3g} expected-fit {r[j]:.3g} N*m" for j in b]
    return (f"verdict {rep['verdict']}, {rep['wall_time_s']} s, effects "
            f"{sorted(named(rep))}\n" + "\n".join(rows))


def test_tx40_windows(tmp_path):
    rep = run([DATA / "tx40_00.csv", DATA / "tx40_01.csv"], tmp_path / "out", plots=False)
    print(summary(rep))
    errs = check(rep)
    assert not errs, errs
    # the wrist motor turns with q5 + q6 (the sidecar's transmission): its coupling is a candidate and,
    # on this log, named
    assert any(n.startswith("coupled_") and j == "joint_6" for n, j in named(rep))


@pytest.mark.slow
def test_tx40_whole_log_5khz(tmp_path):
    out = tmp_path / "trials"
    assert im.main(["--source", str(DATA / "source"), "--urdf", str(DATA / im.URDF_NAME),
                    "--out", str(out)]) == 0
    trials = sorted(out.glob("*.csv"))
    rep = run(trials, tmp_path / "out", plots=True)
    print(summary(rep))
    assert rep["trials"][0]["samples"] + rep["trials"][1]["samples"] == 45_000
    errs = check(rep)
    assert not errs, errs
