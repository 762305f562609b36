"""The gap workflow on the spine's own logs, over LCM: `spine-node --motors lcm` and `bench-robot
--experiment ident` (the identification excitation) as separate processes in a network namespace, recorded
by `lcm-logger`, then `gap run` on the log. The bench plant's truth is known (`sim.plant.PlantConfig()`:
Stribeck friction at NOMINAL_FRICTION x (0.9, 0.9, 0.6, 0.5), reflected rotor inertia 0.0018 kg*m^2, CyberGear
quantisation, sensor noise, the rig's push read by its load cell).

- the plant as it is: its Coulomb and viscous friction and rotor inertia on every actuated joint within
  25 %, and no effect the plant does not have;
- an effect hidden with `bench-robot --effect` on one joint, the plant's known friction and inertia given
  as the nominal plant: named on that joint, its parameter within 15 %, nothing else named but a
  re-estimate of the known inertia within 2 % (one case in the default suite, the other kinds the bench
  takes are `slow`).
"""

from __future__ import annotations

import pytest

from sparc_quad.gap.workflow import run
from tests.gap_helpers import bench_truth_effects, record_session, write_bench_truth_plant
from tests.node_netns import unshare_prefix

needs_netns = pytest.mark.skipif(unshare_prefix() is None, reason="cannot create a network namespace here")
pytestmark = [needs_netns, pytest.mark.netns, pytest.mark.integration]  # processes over LCM
IDENT = "--experiment ident --duration 20"
TRUTH_TOL = 0.25
HIDDEN_TOL = 0.15
FRICTION_AND_INERTIA = {"coulomb_friction": "tau_c_nm", "viscous_friction": "b_nm_s_rad",
                        "rotor_inertia": "inertia_kg_m2"}


@pytest.fixture(scope="module")
def plain_session(tmp_path_factory):
    out = tmp_path_factory.mktemp("ident_plain")
    log, logs = record_session(out, IDENT)
    return run([log], out / "gap", plots=False), logs, out / "gap" / "plant.json"


def identified_bench_plant(plant_json):
    """docs/gap.md's last step: the identified plant.json into the simulated bench, with no friction or
    rotor inertia built in beside it (the log's effects carry all of them)."""
    from sparc_quad.effects.plant import PlantEffects
    from sparc_quad.sim.plant import PlantConfig
    from spine_module import params as P

    return PlantConfig(friction=P.NOMINAL_FRICTION.scaled(coulomb=0.0, static=0.0, viscous=0.0),
                       armature_kg_m2=0.0, effects=PlantEffects.load(plant_json))


def test_bench_plant_friction_and_inertia_from_its_log(plain_session):
    rep, logs, _ = plain_session
    print(f"named {[(e['name'], e['joint'], e['params']) for e in rep['effects']]}"
          f"; verdict {rep['verdict']}; gap/floor {rep['gap_after_over_floor']}; floor {rep['noise_floor']}")
    truth = {(e.name, e.joint): e.params for e in bench_truth_effects()[0]}
    named = {(e["name"], e["joint"]): e["params"] for e in rep["effects"]}
    errs = []
    for (name, joint), params in truth.items():
        if name not in FRICTION_AND_INERTIA:
            continue
        key = FRICTION_AND_INERTIA[name]
        if (name, joint) not in named:
            errs.append(f"{name}@{joint} not named")
        elif abs(named[(name, joint)][key] / params[key] - 1) > TRUTH_TOL:
            errs.append(f"{name}@{joint}: {named[(name, joint)][key]:.5g} vs the plant's {params[key]:.5g}")
    # the plant's friction also has a Stribeck excess: naming it is right, anything else is not
    extra = [k for k in named if k not in truth]
    assert not errs and not extra and not rep["ambiguous"], (errs, extra, rep["ambiguous"], named, logs)
    assert all(v > 0 for v in rep["noise_floor"].values())
    assert rep["log_sources"][0]["columns"]["f_ext_x"].startswith("SPARC_SPINE_STATE.load_cell[0]")


def test_identified_plant_loads_into_the_simulated_bench(plain_session):
    """The plant.json, loaded as docs/gap.md says, gives the bench's friction torque within 25 % over the
    speeds the run covered and its rotor inertia, and the bench world runs with it."""
    import json

    import numpy as np

    from sparc_quad.sim.bench_world import BenchWorld
    from sparc_quad.sim.plant import PlantConfig
    from spine_module.control.friction import StribeckFriction

    _, _, plant_json = plain_session
    cfg = PlantConfig.from_json(json.loads(json.dumps(identified_bench_plant(plant_json).to_json())))
    truth = PlantConfig()
    dq = np.array([0.05, 0.2, 0.5, 1.0, 2.0])
    want = np.array([StribeckFriction([truth.friction] * 3).torque(np.full(3, v)).copy() for v in dq])
    got = np.array([cfg.effects.friction_torque(np.full(3, v)) for v in dq])
    np.testing.assert_allclose(-got, want, rtol=0.25)
    np.testing.assert_allclose(cfg.effects.armature(), truth.armature_kg_m2, rtol=0.25)
    with BenchWorld(plant=cfg) as world:
        for _ in range(100):
            world.step(np.zeros(3))
        assert np.all(np.isfinite(world.state().q))


@pytest.mark.slow
def test_bench_plant_gap_closed(plain_session):
    """The bench plant as it is: its friction and rotor inertia explain the log to within its noise
    floor (this failed at 2.2x and 3.8x the floor on q2 and q4 while the bench integrated its friction
    backward-Euler and the residual at the step's midpoint, sim/bench_world.py).

    Slow tier, on an idle machine: on a loaded one lcm-logger loses spine states that the loader fills in
    linearly, and the filled samples leave residual above the 1.1 x floor margin
    (notebook/2026-12-07-test-docstring-figures.md). Keeping filled samples out of the fit is the fix."""
    rep, _, _ = plain_session
    assert rep["verdict"] == "gap_closed", rep["gap_after_over_floor"]


# one joint per effect where the excitation moves it well; the hidden value differs from the synth default
# where that default is smaller than the bench's own friction would let be seen
HIDDEN = {
    "torque_gain": ("torque_gain:joint=q2,gain=0.85", "gain"),
    "coulomb_friction": ("coulomb_friction:joint=q3,tau_c_nm=0.05", "tau_c_nm"),
    "viscous_friction": ("viscous_friction:joint=q2,b_nm_s_rad=0.03", "b_nm_s_rad"),
    "rotor_inertia": ("rotor_inertia:joint=q3,inertia_kg_m2=0.003", "inertia_kg_m2"),
    "torque_offset": ("torque_offset:joint=q3,offset_nm=0.1", "offset_nm"),
    "time_delay": ("time_delay:joint=q2,delay_s=0.008", "delay_s"),
    "encoder_offset": ("encoder_offset:joint=q2,offset_rad=0.05", "offset_rad"),
    "torque_deadband": ("torque_deadband:joint=q3,width_nm=0.1", "width_nm"),
    "torque_saturation": ("torque_saturation:joint=q3,limit_nm=0.5", "limit_nm"),
    "stribeck_friction": ("stribeck_friction:joint=q3,tau_s_nm=0.1,dq_s_rad_s=0.3", "tau_s_nm"),
    "asymmetric_coulomb": ("asymmetric_coulomb:joint=q3,delta_nm=0.03", "delta_nm"),
}
DEFAULT_CASE = "torque_gain"


@pytest.mark.parametrize("name", [pytest.param(n, marks=() if n == DEFAULT_CASE else pytest.mark.slow)
                                  for n in HIDDEN])
def test_hidden_effect_named_on_its_joint(tmp_path, name):
    spec, key = HIDDEN[name]
    log, logs = record_session(tmp_path, f"{IDENT} --effect {spec}")
    known = write_bench_truth_plant(tmp_path / "bench_known.json")
    rep = run([log], tmp_path / "gap", nominal_plant=known, plots=False)
    joint = spec.split("joint=")[1].split(",")[0]
    value = float(spec.split(f"{key}=")[1].split(",")[0])
    named = [e for e in rep["effects"] if e["name"] == name and e["joint"] == joint]
    print(f"{spec}: named {[(e['name'], e['joint'], e['params']) for e in rep['effects']]}; verdict "
          f"{rep['verdict']}; gap/floor {rep['gap_after_over_floor']}")
    assert named, ([(e["name"], e["joint"], e["params"]) for e in rep["effects"]], rep["ambiguous"], logs)
    assert abs(named[0]["params"][key] / value - 1) <= HIDDEN_TOL, (named[0], value)
    # nothing else, but for a re-estimate of the known inertia about that joint's axis within
    # INERTIA_REESTIMATE, named as rotor inertia or as the equivalent link inertia (or ambiguous between them)
    # (the bench's backward-Euler friction step shifts it by about a per cent:
    # notebook/2026-12-07-test-docstring-figures.md)
    others = [(e["name"], e["joint"], e["params"]) for e in rep["effects"]
              if e is not named[0] and not _inertia_reestimate(e)]
    unclear = [a["best"] for a in rep["ambiguous"] if not _inertia_reestimate(a["best"])]
    assert not others and not unclear, (others, unclear)


INERTIA_REESTIMATE = 0.02  # of the bench's rotor inertia


def _inertia_reestimate(entry: dict) -> bool:
    """A rotor inertia, or a link's rotational inertia (param_index 4-9: Ixx..Izz), of at most
    INERTIA_REESTIMATE x the bench's rotor inertia: the known inertia re-estimated, not another effect."""
    from sparc_quad.sim.plant import PlantConfig

    limit = INERTIA_REESTIMATE * PlantConfig().armature_kg_m2
    if entry["name"] == "rotor_inertia":
        return abs(entry["params"]["inertia_kg_m2"]) <= limit
    if entry["name"] == "link_inertia":
        return 4 <= entry["params"]["param_index"] <= 9 and abs(entry["params"]["delta"]) <= limit
    return False
