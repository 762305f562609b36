"""Shared helpers for the gap workflow tests (not a test module)."""

from __future__ import annotations

import json
import shutil
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


def record_session(out: Path, robot_args: str, node_args: str = "--soft-start 0",
                   timeout_s: float = 600.0) -> tuple[Path, str]:
    """`spine-node --motors lcm` + `bench-robot ROBOT_ARGS` (lockstep) recorded by `lcm-logger`, as separate
    processes on UDP multicast in a private network namespace (the harness of tests/conftest.py::lcm_run):
    the robot starts once the logger has recorded a start mark, the logger stops once it has recorded an
    end mark. Returns (the log, the processes' stderr tails)."""
    import shlex
    import sys

    from spine_module.messages import channels
    from tests import lcm_mark
    from tests.node_netns import UDP_COUNTERS, lcm_tool, run_in_netns

    root = Path(__file__).resolve().parents[1]
    out.mkdir(parents=True, exist_ok=True)
    py = shlex.quote(sys.executable)
    url = shlex.quote(channels.DEFAULT_URL.replace("recv_buf_size=2097152", "recv_buf_size=4194304"))
    log = out / "session.lcmlog"
    script = f"""
export PYTHONPATH={shlex.quote(str(root))}
{py} -m sparc_quad spine-node --motors lcm --clock lockstep --idle-timeout 5 {node_args} \
    --summary {out}/node.json > {out}/node.out 2> {out}/node.err &
NODE=$!
{shlex.quote(lcm_tool("lcm-logger"))} -q --lcm-url={url} -f {log} > {out}/logger.out 2>&1 &
LOGGER=$!
{py} -m tests.lcm_mark {url} {lcm_mark.START} {log} 2> {out}/mark.err
{py} -m sparc_quad bench-robot --clock lockstep {robot_args} --out {out}/robot > {out}/robot.out \
    2> {out}/robot.err
wait $NODE
{py} -m tests.lcm_mark {url} {lcm_mark.END} {log} 2>> {out}/mark.err
kill -INT $LOGGER
wait $LOGGER || true
""" + UDP_COUNTERS.format(out=out)
    r = run_in_netns(script, root, timeout_s=timeout_s)
    logs = "\n".join(f"--- {p.name}\n{p.read_text()[-3000:]}" for p in sorted(out.glob("*.err")))
    assert r.returncode == 0, f"rc={r.returncode}\n{r.stderr}\n{logs}"
    return log, logs


def bench_truth_effects():
    """The bench plant's own friction and rotor inertia (`sim.plant.PlantConfig()`, the truth a log of it
    should give) as effect-library entries: Coulomb, the Stribeck excess, viscous, rotor inertia on every
    actuated joint, and the tanh smoothing (1 / beta) of its friction law."""
    from sparc_quad.effects.base import Effect
    from sparc_quad.sim.plant import PlantConfig
    from spine_module import params as P

    cfg = PlantConfig()
    f = cfg.friction
    eff = []
    for j in P.ACTUATED_JOINTS:
        eff += [Effect("coulomb_friction", j, {"tau_c_nm": f.tau_c_nm}),
                Effect("stribeck_friction", j, {"tau_s_nm": f.tau_s_nm - f.tau_c_nm,
                                                 "dq_s_rad_s": f.dq_s_rad_s}),
                Effect("viscous_friction", j, {"b_nm_s_rad": f.b_nm_s_rad}),
                Effect("rotor_inertia", j, {"inertia_kg_m2": cfg.armature_kg_m2})]
    return eff, 1.0 / f.beta_s_rad


def write_bench_truth_plant(path: Path) -> Path:
    """The bench plant's known friction and rotor inertia as a plant-effects file (`gap run --plant`)."""
    from sparc_quad.effects.plant import PlantEffects
    from spine_module import params as P

    eff, eps = bench_truth_effects()
    PlantEffects(list(P.ACTUATED_JOINTS), eff, eps).save(path)
    return path


def copy_trial(good: Path, tmp_path: Path, name: str | None = None) -> Path:
    """A trial CSV and its sidecar copied into `tmp_path` (as `name`.csv, default its own name), the
    sidecar's URDF and plant made absolute so the copy loads where it is."""
    dst = tmp_path / (f"{name}.csv" if name else good.name)
    shutil.copy(good, dst)
    meta = json.loads(good.with_suffix(".json").read_text())
    meta["urdf"] = str((good.parent / meta["urdf"]).resolve())
    meta["plant"] = str((good.parent / meta["plant"]).resolve())
    dst.with_suffix(".json").write_text(json.dumps(meta))
    return dst


def edit_meta(p: Path, **changes) -> None:
    """Change keys of a trial's sidecar."""
    side = p.with_suffix(".json")
    meta = json.loads(side.read_text())
    meta.update(changes)
    side.write_text(json.dumps(meta))
