"""Which effects to name: a stepwise subset search that does not lock in early surrogates.

Each forward step tries every single effect on every joint and, per joint, the physically expected group
(Coulomb + viscous friction + rotor inertia, the terms not yet in the model) as one step; the candidate
with the lowest BIC that passes wins (dBIC <= -BIC_MIN on the training blocks, held-out residual on the
joints it acts on improved by >= HELDOUT_MIN_PCT, contribution >= MIN_CONTRIBUTION noise floors,
parameters plausible for this robot). Every forward step is followed by backward elimination: a term
whose removal costs less than BIC_MIN, that no longer improves its joints' held-out residual, or whose
parameters became implausible in the joint fit, is dropped (a surrogate that an added physical effect has
made redundant goes). Model sets already visited are not revisited, so the search ends.

Plausibility bounds are scaled from the robot and the data (per joint: torque range = max(URDF effort
limit, peak |torque|), RMS velocity and acceleration while moving; the robot's total mass), not from the
spine. With `torque_kind: measured`, effects that act on the command (delay, deadband, saturation) are
not candidates; a saturation limit must be exceeded by the commanded torque on 0.5-30 % of the samples.
Near-ties are reported as ambiguous only between effects on the same joint (effects on different joints
leave different residuals).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sparc_quad.gap.identify import (
    AMBIGUOUS_BIC,
    BIC_MIN,
    HELDOUT_MIN_PCT,
    HELDOUT_TIE,
    MIN_CONTRIBUTION,
    Fit,
    Selector,
    Term,
    term_effect,
    term_params,
)
from sparc_quad.sim.plant_effects import COUPLED, EFFECT_NAMES, PlantEffectsError

ON_COMMAND = ("time_delay", "torque_saturation", "torque_deadband")
GROUP = ("coulomb_friction", "viscous_friction", "rotor_inertia")
MULTI_JOINT = ("payload_mass", "encoder_offset", "link_inertia", *COUPLED)
SATURATED_FRACTION = (0.005, 0.30)


@dataclass
class JointScale:
    tau_range: float  # N*m: max(URDF effort limit, peak |torque| in the training data)
    tau_peak: float  # N*m: peak |torque| in the training data
    dq_rms: float  # rad/s, moving samples
    ddq_rms: float  # rad/s^2, moving samples
    abs_tau: np.ndarray  # |torque| samples (training), for the saturation check


@dataclass
class StepRecord:
    term: Term
    delta_bic: float
    heldout_improvement_pct: float
    ambiguous_with: list[dict]


def scales(sel: Selector) -> tuple[dict[str, JointScale], float]:
    """Per-joint scales and the robot's total mass (kg)."""
    rb = sel.robot
    out = {}
    for ja, j in enumerate(rb.actuated):
        v = int(rb.act_idx[ja])
        tau = np.concatenate([np.abs(sel.lib.blocks[b].trial.tau_cmd[:, ja]) for b in sel.train])
        dq = np.concatenate([sel.lib.blocks[b].dq_f[:, v] for b in sel.train])
        ddq = np.concatenate([sel.lib.blocks[b].ddq_f[:, v] for b in sel.train])
        moving = np.abs(dq) > 0.1 * np.sqrt(np.mean(dq**2))
        lim = float(rb.model.effortLimit[v])
        peak = float(tau.max())
        dq_rms = float(np.sqrt(np.mean(dq[moving] ** 2))) if moving.any() else 1e-3
        ddq_rms = float(np.sqrt(np.mean(ddq[moving] ** 2))) if moving.any() else 1e-3
        out[j] = JointScale(max(lim, peak), peak, dq_rms, ddq_rms, tau)
    mass = float(sum(rb.model.inertias[i].mass for i in range(1, rb.model.njoints)))
    return out, mass


def plausible(t: Term, sc: JointScale, total_mass_kg: float) -> str | None:
    """None when the fitted parameters are physically possible for this robot, else the reason."""
    p, se = term_params(t)
    b_max = sc.tau_range / max(sc.dq_rms, 1e-3)
    i_max = sc.tau_range / max(sc.ddq_rms, 1e-3)
    m_max = max(2.0 * total_mass_kg, 1.0)
    checks = {
        "coulomb_friction": (0 < p.get("tau_c_nm", 0) < 0.5 * sc.tau_range,
                             f"Coulomb friction must be in (0, {0.5 * sc.tau_range:.3g}) N*m"),
        "viscous_friction": (0 < p.get("b_nm_s_rad", 0) < b_max,
                             f"viscous coefficient must be in (0, {b_max:.3g}) N*m*s/rad"),
        "stribeck_friction": (0 < p.get("tau_s_nm", 0) < 0.5 * sc.tau_range
                              and 1e-3 <= p.get("dq_s_rad_s", 0) <= 5 * max(sc.dq_rms, 1.0),
                              "Stribeck excess must be positive, its velocity within the data's range"),
        "rotor_inertia": (0 < p.get("inertia_kg_m2", 0) < i_max,
                          f"rotor inertia must be in (0, {i_max:.3g}) kg*m^2"),
        "torque_gain": (0.3 < p.get("gain", 0) < 1.5, "torque gain must be in (0.3, 1.5)"),
        "torque_offset": (abs(p.get("offset_nm", 0)) < 0.25 * sc.tau_range,
                          "offset beyond a quarter of the torque range"),
        "time_delay": (0 < p.get("delay_s", 0) <= 0.05, "delay must be in (0, 50 ms]"),
        "payload_mass": (0 < p.get("mass_kg", 0) < m_max, f"payload mass must be in (0, {m_max:.3g}) kg"),
        "encoder_offset": (abs(p.get("offset_rad", 0)) < 0.5, "encoder offset beyond 0.5 rad"),
        "torque_saturation": (0 < p.get("limit_nm", 0) < sc.tau_peak,
                              "limit must lie below the peak command"),
        "torque_deadband": (0 < p.get("width_nm", 0) < 0.5 * sc.tau_peak,
                            "deadband must be below half the peak"),
        "link_inertia": (np.isfinite(p.get("delta", np.nan)), "not finite"),
        "asymmetric_coulomb": (abs(p.get("delta_nm", 0)) < 0.5 * sc.tau_range,
                               "Coulomb asymmetry beyond half the torque range"),
        "coupled_rotor_inertia": (0 < p.get("inertia_kg_m2", 0) < i_max,
                                  f"coupled rotor inertia must be in (0, {i_max:.3g}) kg*m^2"),
        "coupled_coulomb_friction": (0 < p.get("tau_c_nm", 0) < 0.5 * sc.tau_range,
                                     "coupled Coulomb friction must be in (0, torque range / 2)"),
        "coupled_viscous_friction": (0 < p.get("b_nm_s_rad", 0) < b_max,
                                     f"coupled viscous coefficient must be in (0, {b_max:.3g})"),
    }
    ok, why = checks[t.name]
    if not ok:
        return why
    if t.name == "torque_saturation":
        frac = float(np.mean(sc.abs_tau > p["limit_nm"]))
        lo, hi = SATURATED_FRACTION
        if not lo <= frac <= hi:
            return (f"commanded torque exceeds the limit on {100 * frac:.1f} % of the samples (a clipped "
                    f"signature needs {100 * lo:.1f}-{100 * hi:.0f} %)")
    for k, v in se.items():
        val = p[k]
        if isinstance(val, float) and np.isfinite(v) and abs(val) < 2 * v:
            return f"{k} not distinguishable from zero ({val:.3g} +- {v:.2g})"
    return None


class Search:
    """State of one stepwise search (see the module docstring)."""

    def __init__(self, sel: Selector, torque_kind: str = "commanded",
                 couplings: list[tuple[str, np.ndarray]] = ()):
        self.sel = sel
        self.rb = sel.robot
        self.scale, self.mass = scales(sel)
        self.names = [n for n in EFFECT_NAMES if not (torque_kind == "measured" and n in ON_COMMAND)
                      and n not in COUPLED and n not in ("asymmetric_coulomb", "link_inertia")]
        self.couplings = list(couplings)
        self.log: list[dict] = []

    def joints_of(self, t: Term) -> list[int]:
        if t.direction is not None:
            return [int(v) for v in self.rb.act_idx[np.abs(t.direction) > 0]]
        if t.name in MULTI_JOINT:
            return list(range(self.rb.nv))
        return [int(self.rb.act_idx[self.rb.actuated.index(t.joint)])]

    def improvement(self, with_: Fit, without: Fit, terms: list[Term]) -> float:
        """Held-out improvement (%) on the joints the terms act on."""
        if not self.sel.test:
            return float("nan")
        js = sorted({v for t in terms for v in self.joints_of(t)})
        a, b = float(np.sum(with_.heldout_mse_joint[js])), float(np.sum(without.heldout_mse_joint[js]))
        return 100.0 * (1.0 - a / b) if b > 0 else 0.0

    def assign(self, terms: list[Term]) -> Fit:
        """Fit with standard errors; writes coef/se into the linear terms."""
        fit = self.sel.fit(terms, with_se=True)
        i = 0
        for t in terms:
            if not t.fixed:
                t.coef, t.se, t.coef_index = float(fit.beta[i]), float(fit.se[i]), i
                i += 1
        return fit

    def contribution(self, fit: Fit, terms: list[Term]) -> float:
        """RMS (noise floors) of the terms' fitted contribution on their most affected joint, held out."""
        sel = self.sel
        blocks = sel.test or sel.train
        lin = [t for t in fit.terms if not t.fixed]
        tot = None
        for t in terms:
            col = np.vstack([sel.lib.column(t, bi) for bi in blocks]) * sel.w
            if not t.fixed:
                col = col * fit.beta[lin.index(t)]
            tot = col if tot is None else tot + col
        return float(np.max(np.sqrt(np.mean(tot**2, axis=0))))

    def significant(self, selected: list[Term], terms: list[Term]) -> list[Term]:
        """Of a link's base parameters, those > 2 standard errors when fitted together (all if none)."""
        self.assign([*selected, *terms])
        keep = [t for t in terms if np.isfinite(t.se) and abs(t.coef) > 2 * t.se]
        return keep or terms

    def why_not(self, terms: list[Term], fit: Fit) -> str | None:
        for t in terms:
            why = plausible(t, self.scale[t.joint], self.mass)
            if why:
                return f"{t.name}@{t.joint}: {why}"
        links = [term_effect(t) for t in fit.terms if t.name == "link_inertia"]
        if links:  # the corrected bodies must still have a positive mass
            try:
                self.sel.lib.nominal.with_effects(links).apply_to_pinocchio(self.rb.model)
            except PlantEffectsError as exc:
                return str(exc)
        return None

    def candidates(self, selected: list[Term], cur: Fit, visited: set) -> list[tuple]:
        sel = self.sel
        taken = {t.key for t in selected}
        out = []
        options: list[list[Term] | tuple[str, str]] = []
        for name in self.names:
            for joint in self.rb.actuated:
                if (name, joint) not in taken:
                    options.append((name, joint))
        for joint in self.rb.actuated:
            rest = [n for n in GROUP if (n, joint) not in taken and n in self.names]
            if len(rest) >= 2:
                options.append([Term(n, joint) for n in rest])
            # a direction-dependent Coulomb level refines a Coulomb friction already in the model
            if ("coulomb_friction", joint) in taken and ("asymmetric_coulomb", joint) not in taken:
                options.append([Term("asymmetric_coulomb", joint)])
        for joint in self.rb.actuated:  # link inertial-parameter errors: the body's base parameters
            base = sel.lib.base_parameters(sel.train)
            jid = self.rb.model.getJointId(joint)
            link = [Term("link_inertia", joint, param_index=c, combination=base.combination(c),
                         link=self.rb.child_link(joint)) for c in base.columns_of(jid)]
            link = [t for t in link if t.key not in taken]
            if link:
                options.append(self.significant(selected, link))
        for joint, u in self.couplings:  # a motor that turns with several joints (transmission)
            rest = [Term(n, joint, direction=u) for n in COUPLED if (n, joint) not in taken]
            options += [[t] for t in rest]
            if len(rest) >= 2:
                options.append(rest)
        for opt in options:
            if isinstance(opt, tuple):
                term, fit = sel.candidate(selected, *opt)
                new = [term]
            else:
                new = opt
                fit = sel.fit([*selected, *new])
            keys = frozenset({*taken, *(t.key for t in new)})
            if keys in visited:
                continue
            dbic = fit.bic - cur.bic
            imp = self.improvement(fit, cur, new)
            if dbic > -BIC_MIN:  # cheap rejection first: no standard errors needed
                out.append((fit.bic, new, fit, dbic, imp, f"dBIC {dbic:.1f} > -{BIC_MIN}"))
                continue
            full = self.assign([*selected, *new])
            why = self.why_not(new, full)
            size = self.contribution(fit, new)
            if size < MIN_CONTRIBUTION:
                why = why or f"contribution {size:.2f} x noise floor < {MIN_CONTRIBUTION}"
            if sel.test and not imp >= HELDOUT_MIN_PCT:
                why = why or f"held-out improvement {imp:.2f} % < {HELDOUT_MIN_PCT} %"
            out.append((fit.bic, new, fit, dbic, imp, why))
        out.sort(key=lambda c: c[0])
        return out

    def backward(self, selected: list[Term], steps: list[StepRecord], visited: set) -> tuple[list[Term], Fit]:
        """Drop terms that no longer pay (see the module docstring), worst first, until none."""
        sel = self.sel
        while True:
            cur = sel.fit(selected)
            self.assign(selected)
            worst = None
            for t in selected:
                rest = [x for x in selected if x is not t]
                without = sel.fit(rest)
                gain = without.bic - cur.bic  # what keeping t is worth
                imp = self.improvement(cur, without, [t])
                why = plausible(t, self.scale[t.joint], self.mass)
                if why is None and t.name == "asymmetric_coulomb" and \
                        ("coulomb_friction", t.joint) not in {x.key for x in rest}:
                    why = "refines a Coulomb friction no longer in the model"
                if why is None and gain < BIC_MIN:
                    why = f"worth dBIC {-gain:.1f} > -{BIC_MIN} now"
                if why is None and sel.test and not imp >= HELDOUT_MIN_PCT:
                    why = f"held-out improvement {imp:.2f} % < {HELDOUT_MIN_PCT} % now"
                if why and (worst is None or gain < worst[1]):
                    worst = (t, gain, why)
            if worst is None:
                return selected, cur
            t, _gain, why = worst
            selected = [x for x in selected if x is not t]
            steps[:] = [s for s in steps if s.term is not t]
            self.log.append({"removed": {"name": t.name, "joint": t.joint}, "because": why})
            visited.add(frozenset(x.key for x in selected))

    def run(self, max_effects: int | None = None) -> tuple[list[StepRecord], Fit, list[dict]]:
        sel = self.sel
        selected: list[Term] = []
        cur = sel.fit([])
        steps: list[StepRecord] = []
        visited: set = {frozenset()}
        while max_effects is None or len(selected) < max_effects:
            cands = self.candidates(selected, cur, visited)
            passing = [c for c in cands if c[5] is None]
            if max_effects is not None:
                passing = [c for c in passing if len(selected) + len(c[1]) <= max_effects]
            self.log.append({"step": len(self.log) + 1, "top": [
                {"effects": [f"{t.name}@{t.joint}" for t in c[1]], "delta_bic": round(c[3], 2),
                 "heldout_improvement_pct": round(c[4], 3), "rejected_because": c[5]} for c in cands[:6]]})
            if not passing:
                break
            best = passing[0]
            # near-ties on the training blocks between effects on the same joint: the held-out blocks may
            # separate them; those within HELDOUT_TIE of the best on held-out data stay ambiguous
            joint = best[1][0].joint
            group = [c for c in passing if c[0] - best[0] < AMBIGUOUS_BIC and len(c[1]) == 1
                     and c[1][0].joint == joint] if len(best[1]) == 1 else [best]
            if sel.test and len(group) > 1:
                group.sort(key=lambda c: c[2].heldout_mse)
                group = [c for c in group if c[2].heldout_mse <= HELDOUT_TIE * group[0][2].heldout_mse]
            best, rivals = group[0], group[1:]
            self.assign(best[2].terms)
            amb = [{"name": c[1][0].name, "joint": c[1][0].joint,
                    "delta_bic_vs_best": round(c[0] - best[0], 2),
                    "heldout_mse_vs_best": round(c[2].heldout_mse / best[2].heldout_mse, 4),
                    "params": term_params(c[1][0])[0]} for c in rivals]
            selected = list(best[2].terms)
            for t in best[1]:
                steps.append(StepRecord(t, best[3], best[4], amb))
            visited.add(frozenset(t.key for t in selected))
            selected, cur = self.backward(selected, steps, visited)
        final = self.assign(selected)
        return steps, final, self.log


def couplings_from(meta: dict, actuated: list[str]) -> list[tuple[str, np.ndarray]]:
    """Motors that turn with more than one joint, from the sidecar's transmission: motor m's angle is row m
    of G^-1 applied to the joint angles; a row with >= 2 non-zero entries is a coupled motor. Returns
    (the joint listed with that motor, direction u = the row scaled to max |u| = 1)."""
    tr = meta.get("transmission")
    if not tr:
        return []
    Ginv = np.linalg.inv(np.asarray(tr["motor_to_joint"], float))
    out = []
    for m, row in enumerate(Ginv):
        big = np.abs(row) > 1e-9 * np.abs(row).max()
        if big.sum() >= 2:
            out.append((actuated[m], row / np.abs(row).max()))
    return out


def select(sel: Selector, max_effects: int | None = None, torque_kind: str = "commanded",
           couplings: list[tuple[str, np.ndarray]] = ()):
    """(accepted steps, final fit, log) of the stepwise search."""
    return Search(sel, torque_kind, couplings).run(max_effects)
