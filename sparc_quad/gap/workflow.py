"""`gap TRIAL... --out DIR`: filter, residual, noise floor, locate, name (select.py), add, report.

Jobs in order, one module each: filtering.py (blocks), residual.py, noise_floor.py, regressors.py (the
effects' columns), fitting.py (least squares, BIC, held-out), select.py (which effects to name); the
effects themselves are sparc_quad.effects."""

from __future__ import annotations

import json
import logging
import time
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from sparc_quad.effects.plant import PlantEffects
from sparc_quad.gap import select as S
from sparc_quad.gap.errors import NumericalError
from sparc_quad.gap.filtering import Block
from sparc_quad.gap.fitting import Selector
from sparc_quad.gap.noise_floor import noise_floor
from sparc_quad.gap.regimes import REGIMES
from sparc_quad.gap.regressors import Library
from sparc_quad.gap.replay import replay
from sparc_quad.gap.residual import residual
from sparc_quad.gap.resolution_floor import resolution_floor
from sparc_quad.gap.trial import Trial, TrialError, is_lcm_log, load_lcm_segments, load_trial, robot_for

log = logging.getLogger(__name__)
GAP_CLOSED_FACTOR = 1.1


def load_trials(paths: Sequence[str | Path]) -> list[Trial]:
    if not paths:
        raise TrialError("<command line>", "no trials given")
    trials: list[Trial] = []
    robot = None
    loaded: list[tuple[Path, Trial]] = []
    for p in paths:
        p = Path(p)
        if is_lcm_log(p):  # a session log: every segment between unfillable gaps is a trial
            loaded += [(p, tr) for tr in load_lcm_segments(p)]
        else:
            loaded.append((p, load_trial(p, robot)))
        if robot is None:
            robot = loaded[0][1].robot
    for p, tr in loaded:
        if trials:
            first = trials[0].meta
            for key in ("urdf", "actuated_joints", "fixed_joints", "gravity", "rate_hz"):
                if tr.meta.get(key) != first.get(key) and key != "urdf":
                    raise TrialError(p.with_suffix(".json"), f"{key} differs from {trials[0].path}",
                                     column=key)
            if robot_for(p, tr.meta).urdf != robot.urdf and \
                    Path(robot_for(p, tr.meta).urdf).resolve() != Path(robot.urdf).resolve():
                raise TrialError(p.with_suffix(".json"), "urdf differs from the first trial", column="urdf")
        trials.append(tr)
    return trials


CUTOFF_OVER_BANDWIDTH = 6.0
BANDWIDTH_ENERGY = 0.99
CUTOFF_MIN_HZ = 5.0


def choose_cutoff(trials: list[Trial]) -> tuple[float, float]:
    """(low-pass cut-off, motion bandwidth), Hz, from the data: per joint, the frequency under which
    BANDWIDTH_ENERGY of the measured velocity's energy lies (Welch); the bandwidth is the median over
    joints (a noisy velocity of one light joint, e.g. a massless flange, does not set it), max over trials;
    the cut-off CUTOFF_OVER_BANDWIDTH times it (room for effects that act faster than the motion, e.g. a
    delay or friction at reversals), within [CUTOFF_MIN_HZ, rate/10]."""
    from scipy.signal import welch

    bw = 0.0
    for tr in trials:
        f, P = welch(tr.dq, fs=tr.rate_hz, nperseg=min(len(tr.t), round(4 * tr.rate_hz)), axis=0)
        c = np.cumsum(P, axis=0)
        per_joint = [float(f[min(np.searchsorted(c[:, v] / c[-1, v], BANDWIDTH_ENERGY), len(f) - 1)])
                     for v in range(P.shape[1]) if c[-1, v] > 0]
        if per_joint:
            bw = max(bw, float(np.median(per_joint)))
    rate = trials[0].rate_hz
    return float(np.clip(CUTOFF_OVER_BANDWIDTH * bw, CUTOFF_MIN_HZ, rate / 10)), bw


def split(trials: list[Trial], heldout_fraction: float = 1 / 3) -> tuple[list[Trial], list[bool]]:
    """Blocks and a held-out flag per block: whole trials when there are >= 2, else contiguous blocks."""
    if len(trials) >= 2:
        n_test = max(1, round(len(trials) * heldout_fraction))
        flags = [False] * len(trials)
        for i in range(n_test):
            flags[len(trials) - 1 - i * max(1, len(trials) // n_test)] = True
        return trials, flags
    tr = trials[0]
    n = len(tr.t)
    cut = round(n * (1 - heldout_fraction))
    period = tr.meta.get("period_s")
    if period:
        P = round(period * tr.rate_hz)
        if P > 0 and cut // P >= 2 and (n - (cut // P) * P) // P >= 2:
            cut = (cut // P) * P
    return [tr.slice(0, cut, "_train"), tr.slice(cut, n, "_heldout")], [False, True]


def localise(blocks: list[Block], res: list[np.ndarray], floor: np.ndarray, robot) -> dict:
    """Rank joints, regimes and time spans by residual size."""
    allr = np.vstack(res)
    rms = np.sqrt(np.mean(allr**2, axis=0))
    joints = sorted(({"joint": j, "rms_nm": float(rms[v]),
                      "rms_over_floor": float(rms[v] / max(floor[v], 1e-12))}
                     for j, v in zip(robot.joints, range(robot.nv), strict=True)),
                    key=lambda d: -d["rms_over_floor"])
    masks: dict[str, list[np.ndarray]] = {k: [] for k in REGIMES}
    slow = []
    for b, r in zip(blocks, res, strict=True):
        dq, ddq = b.dq_f, b.ddq_f
        tau = np.zeros_like(dq)
        tau[:, robot.act_idx] = b.F(b.trial.tau_cmd)
        vs = np.sqrt(np.mean(dq**2, axis=0))
        masks["near_zero_velocity"].append(np.abs(dq) < 0.1 * vs)
        rev = np.zeros_like(dq, dtype=bool)
        flip = np.sign(dq[1:]) != np.sign(dq[:-1])
        for sh in (0, 1):
            rev[sh:sh + len(flip)] |= flip
        masks["velocity_reversal"].append(rev)
        masks["high_acceleration"].append(np.abs(ddq) > np.percentile(np.abs(ddq), 80, axis=0))
        masks["high_torque"].append(np.abs(tau) > np.percentile(np.abs(tau), 80, axis=0))
        k = max(1, round(1.0 / (b.step * b.trial.dt)))
        kern = np.ones(k) / k
        slow.append(np.column_stack([np.convolve(r[:, v], kern, mode="same") for v in range(robot.nv)]))
    regimes = []
    for v, j in enumerate(robot.joints):
        for name in REGIMES:
            if name == "slow_drift":
                s = np.vstack(slow)[:, v]
                val, frac = float(np.sqrt(np.mean(s**2))), 1.0
            else:
                m = np.vstack(masks[name])[:, v]
                if not m.any():
                    continue
                val, frac = float(np.sqrt(np.mean(allr[m, v] ** 2))), float(m.mean())
            regimes.append({"joint": j, "regime": name, "rms_nm": val, "fraction_of_samples": frac,
                            "rms_over_floor": val / max(float(floor[v]), 1e-12),
                            "rms_over_joint_rms": val / max(float(rms[v]), 1e-12)})
    regimes.sort(key=lambda d: -d["rms_over_floor"])
    spans = []
    for b, r in zip(blocks, res, strict=True):
        t = b.trial.t[b.idx]
        k = max(1, round(0.5 / (b.step * b.trial.dt)))
        for s in range(0, len(t) - k + 1, k):
            seg = r[s:s + k]
            z = np.sqrt(np.mean(seg**2, axis=0)) / np.maximum(floor, 1e-12)
            v = int(np.argmax(z))
            spans.append({"trial": b.trial.name, "t0_s": float(t[s]), "t1_s": float(t[s + k - 1]),
                          "joint": robot.joints[v], "rms_over_floor": float(z[v])})
    spans.sort(key=lambda d: -d["rms_over_floor"])
    return {"joints": joints, "regimes": regimes, "spans": spans[:8]}


def reference_fit(sel: Selector, nominal: PlantEffects, ho_blocks: list[Block]) -> dict:
    """The physically expected model fitted without selection (`select.expected_fit`): its held-out
    residual is the yardstick the selected model is compared with."""
    robot = sel.robot
    terms, fit = S.expected_fit(sel)
    plant = nominal.with_effects([t.effect() for t in terms])
    res = [residual(b, plant) for b in ho_blocks]
    rms = np.sqrt(np.mean(np.vstack(res) ** 2, axis=0))
    return {"effects": [f"{n} on every actuated joint" for n in S.expected_group()], "bic": round(fit.bic, 2),
            "fitted": [{"name": t.name, "joint": t.joint, "params": t.params()[0]} for t in terms],
            "id_residual_rms_nm": _per_joint(robot, rms)}


def _per_joint(robot, arr) -> dict:
    """joint -> value; NaN (not computed, e.g. a joint that cannot be replayed) becomes null."""
    return {j: (float(arr[v]) if np.isfinite(arr[v]) else None) for v, j in enumerate(robot.joints)}


def run(paths: Sequence[str | Path], out: str | Path, *, nominal_plant: str | Path | None = None,
        window_s: float = 0.2, cutoff_hz: float | None = None, plots: bool = True,
        max_effects: int | None = None, trials: list[Trial] | None = None) -> dict:
    """The whole workflow (module docstring). `cutoff_hz` None: chosen from the data (`choose_cutoff`);
    `max_effects` None: no cap (the search ends when no candidate passes); `trials`: `paths` already
    loaded (`load_trials`), so that a caller can check its inputs before it creates anything."""
    t_start = time.perf_counter()
    out = Path(out)
    trials = trials if trials is not None else load_trials(paths)
    robot = trials[0].robot
    plant_file = Path(nominal_plant) if nominal_plant else trials[0].plant_path()
    eps = trials[0].meta.get("friction_smoothing_rad_s")
    nominal = PlantEffects.load(plant_file) if plant_file else \
        PlantEffects(robot.actuated, friction_smoothing_rad_s=eps) if eps else PlantEffects(robot.actuated)
    if nominal.joints != robot.actuated:
        raise TrialError(plant_file, f"plant joints {nominal.joints} != actuated joints {robot.actuated}")
    out.mkdir(parents=True, exist_ok=True)
    parts, heldout = split(trials)
    rate = trials[0].rate_hz
    bandwidth_hz = None
    if cutoff_hz is None:
        cutoff_hz, bandwidth_hz = choose_cutoff(trials)
    step = max(1, round(rate / (2 * cutoff_hz)))
    period = trials[0].meta.get("period_s")
    if period:  # make the decimation step divide the period (repeated-segment noise floor)
        P = round(period * rate)
        while step > 1 and P % step:
            step -= 1
    blocks = [Block(p, robot, cutoff_hz, step) for p in parts]
    res0 = [residual(b, nominal) for b in blocks]
    least, _ = resolution_floor(blocks, nominal)

    def floor_of(bl: list[Block], res: list[np.ndarray]) -> tuple[np.ndarray, str]:
        """The data's noise floor, never below what the sensors resolve (`resolution_floor`)."""
        f, how = noise_floor(bl, res)
        return np.maximum(f, least), how

    floor, floor_method = floor_of(blocks, res0)
    train = [i for i, h in enumerate(heldout) if not h]
    test = [i for i, h in enumerate(heldout) if h]
    loc = localise(blocks, res0, floor, robot)
    lib = Library(blocks, nominal)
    sel = Selector(lib, train, test, res0, floor)
    sel.least_floor = least
    torque_kind = trials[0].torque_kind
    couplings = S.couplings_from(trials[0].meta, robot.actuated)
    steps, final_fit, sel_log = S.select(sel, max_effects, torque_kind, couplings)
    effects, ambiguous, added = [], [], []
    for st in steps:
        t = st.term
        params, se = t.params()
        entry = {"name": t.name, "joint": t.joint, "params": params, "std_err": se,
                 "delta_bic": round(st.delta_bic, 3),
                 "heldout_improvement_pct": round(st.heldout_improvement_pct, 3)}
        if t.link:
            entry["link"] = t.link
        eff = t.effect()
        if st.ambiguous_with:
            entry_alt = [{"name": a["name"], "joint": a["joint"], "params": a["params"],
                          "delta_bic_vs_best": a["delta_bic_vs_best"]} for a in st.ambiguous_with]
            ambiguous.append({"best": entry, "alternatives": entry_alt,
                              "note": "the data cannot separate these; the plant carries the best one"})
            eff.extra["ambiguous_with"] = [f"{a['name']}@{a['joint']}" for a in st.ambiguous_with]
        else:
            effects.append(entry)
        added.append(eff)
    plant = nominal.with_effects(added)
    plant.save(out / "plant.json")
    ho_blocks = [blocks[i] for i in (test or train)]
    res_before = [residual(b, nominal) for b in ho_blocks]
    res_after = [residual(b, plant) for b in ho_blocks]
    ref = reference_fit(sel, nominal, ho_blocks)
    # noise floor on the held-out blocks, where the gap is measured: the spread across periods of the
    # final model's residual (cleaner than the nominal one's, whose unmodelled effects vary with the
    # small period-to-period state differences; an effect the final model misses and that does not
    # repeat raises it, which the report shows beside the nominal-model estimate)
    floor_all = floor
    fb, _ = floor_of(ho_blocks, res_before)
    fa_data, floor_method = noise_floor(ho_blocks, res_after)
    least_final, least_final_parts = resolution_floor(ho_blocks, plant)  # with the named friction's slope
    fa = np.maximum(fa_data, least_final)
    floor = fa
    gap_b = np.sqrt(np.mean(np.vstack(res_before) ** 2, axis=0))
    gap_a = np.sqrt(np.mean(np.vstack(res_after) ** 2, axis=0))
    try:
        rep_b = [replay(b.trial, robot, nominal, window_s) for b in ho_blocks]
        rep_a = [replay(b.trial, robot, plant, window_s) for b in ho_blocks]
    except np.linalg.LinAlgError as exc:
        raise NumericalError(f"replay of the held-out data: {exc} (mass matrix)") from exc
    rb = np.sqrt(np.mean(np.vstack([r["window_rms"] for r in rep_b]) ** 2, axis=0))
    ra = np.sqrt(np.mean(np.vstack([r["window_rms"] for r in rep_a]) ** 2, axis=0))
    closed = bool(np.all(gap_a <= GAP_CLOSED_FACTOR * floor))
    verdict = "gap_closed" if closed else "unexplained_residual"
    report = {
        "verdict": verdict,
        "effects": effects,
        "ambiguous": ambiguous,
        "noise_floor": _per_joint(robot, floor),
        "noise_floor_method": floor_method,
        "noise_floor_set_by": {j: ("sensor_resolution" if least_final[v] >= fa_data[v] else floor_method)
                               for v, j in enumerate(robot.joints)},
        "noise_floor_resolution": {
            "floor_nm": _per_joint(robot, least_final),
            "parts_nm": {k: _per_joint(robot, v) for k, v in least_final_parts.items()},
            "floor_nominal_plant_nm": _per_joint(robot, least),
            "resolution": trials[0].meta.get("resolution"),
            "rule": "sensor LSBs (uniform error, LSB/sqrt(12)) and the load cell's reading error through the "
                    "residual's filter and model terms, plus float64 precision; the floor is never below it"},
        "noise_floor_heldout_nominal_model": _per_joint(robot, fb),
        "noise_floor_heldout_final_model": _per_joint(robot, fa),
        "noise_floor_all_blocks_nominal_model": _per_joint(robot, floor_all),
        "gap_before": {"id_residual_rms_nm": _per_joint(robot, gap_b),
                       "replay_rms_rad": _per_joint(robot, rb)},
        "gap_after": {"id_residual_rms_nm": _per_joint(robot, gap_a),
                      "replay_rms_rad": _per_joint(robot, ra)},
        "selected_bic": round(final_fit.bic, 2),
        "reference_fit": ref,
        "gap_after_over_floor": _per_joint(robot, gap_a / np.maximum(floor, 1e-12)),
        "gap_closed_factor": GAP_CLOSED_FACTOR,
        "model_checks": {"massless_joints": robot.singular_joints,
                         "not_replayed_nominal": rep_b[0]["not_replayed"],
                         "not_replayed_final": rep_a[0]["not_replayed"]},
        "localisation": loc,
        "selection_log": sel_log,
        "settings": {"cutoff_hz": cutoff_hz, "motion_bandwidth_hz": bandwidth_hz,
                     "cutoff_rule": f"{CUTOFF_OVER_BANDWIDTH} x the frequency under which "
                                    f"{100 * BANDWIDTH_ENERGY:g} % of dq's energy lies (median over joints), "
                                    f"clipped to [{CUTOFF_MIN_HZ}, rate/10]" if bandwidth_hz else "given",
                     "decimation_step": step, "decimated_rate_hz": rate / step,
                     "decimation_rule": "one sample per 1 / (2 cutoff): white noise through the low-pass "
                                        "leaves nearly uncorrelated samples",
                     "torque_kind": torque_kind, "max_effects": max_effects,
                     "window_s": window_s, "bic_min": S.BIC_MIN, "heldout_min_pct": S.HELDOUT_MIN_PCT,
                     "ambiguous_bic": S.AMBIGUOUS_BIC,
                     "min_contribution_over_floor": S.MIN_CONTRIBUTION,
                     "nominal_plant": str(plant_file) if plant_file else None},
        "log_sources": _log_sources(trials),
        "trials": [{"block": b.trial.name, "heldout": h, "samples": len(b.trial.t), "decimated": b.n}
                   for b, h in zip(blocks, heldout, strict=True)],
        "robot": {"urdf": robot.urdf, "joints": robot.joints, "actuated": robot.actuated},
        "plant_file": "plant.json",
    }
    report["wall_time_s"] = round(time.perf_counter() - t_start, 3)
    report = finite_json(report)
    (out / "report.json").write_text(json.dumps(report, indent=2, allow_nan=False) + "\n")
    if plots:
        from sparc_quad.gap import report as R
        R.write(out, report, robot, blocks, res0, ho_blocks, res_before, res_after, rep_b, rep_a, floor)
        report["wall_time_s"] = round(time.perf_counter() - t_start, 3)
        (out / "report.json").write_text(json.dumps(report, indent=2, allow_nan=False) + "\n")
    return report


def finite_json(o):
    """`o` as plain JSON values with every NaN or infinity as null (JSON has no token for them)."""
    if isinstance(o, dict):
        return {k: finite_json(v) for k, v in o.items()}
    if isinstance(o, list | tuple):
        return [finite_json(v) for v in o]
    if isinstance(o, np.ndarray):
        return finite_json(o.tolist())
    if isinstance(o, np.generic):
        o = o.item()
    if isinstance(o, float) and not np.isfinite(o):
        return None
    return o


def _log_sources(trials: list[Trial]) -> list[dict]:
    """Per lcm log: its segments, the gaps it was split at, pieces dropped as too short, where each column
    came from and what the log lacks (empty for CSV trials)."""
    out: dict[str, dict] = {}
    for tr in trials:
        src = tr.meta.get("source")
        if not src or "gaps" not in src:
            continue
        e = out.setdefault(src["lcm_log"], {"log": src["lcm_log"], "segments": [], "gaps": src["gaps"],
                                            "dropped_segments": src["dropped_segments"],
                                            "spine_states_in_log": src["spine_states_in_log"],
                                            "columns": tr.meta.get("columns"), "lacks": tr.meta.get("lacks")})
        e["segments"].append({"trial": tr.name, "first_seq": src["first_seq"], "last_seq": src["last_seq"],
                              "filled": len(src["filled_t"])})
    return list(out.values())
