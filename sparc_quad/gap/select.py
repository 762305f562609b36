"""Which effects to name: a stepwise subset search that does not lock in early surrogates.

Each forward step tries every single effect on every joint and, per joint, the physically expected group
(Coulomb + viscous friction + rotor inertia, the terms not yet in the model) as one step; the candidate
with the lowest BIC that passes wins (dBIC <= -BIC_MIN on the training blocks, held-out residual on the
joints it acts on improved by >= HELDOUT_MIN_PCT, contribution >= MIN_CONTRIBUTION noise floors,
parameters plausible for this robot). Every forward step is followed by backward elimination: a term
whose removal costs less than BIC_MIN, that no longer improves its joints' held-out residual, or whose
parameters became implausible in the joint fit, is dropped (a surrogate that an added physical effect has
made redundant goes). Model sets already visited are not revisited, so the search ends.

Each effect kind says which roles it takes in the search (`sparc_quad.effects.base.EffectKind`: alone on
every joint, in the expected group, as a refinement, its own options) and its plausibility bounds.
Plausibility bounds are scaled from the robot and the data (per joint: torque range = max(URDF effort
limit, peak |torque|), RMS velocity and acceleration while moving; the robot's total mass), not from the
spine. With `torque_kind: measured`, effects that act on the command (delay, deadband, saturation) are
not candidates; a saturation limit must be exceeded by the commanded torque on >= 0.5 % of the samples.
Near-ties are reported as ambiguous only between effects on the same joint (effects on different joints
leave different residuals).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sparc_quad.effects import EFFECTS, Term
from sparc_quad.gap.fitting import Fit, Selector
from sparc_quad.gap.noise_floor import noise_floor

BIC_MIN = 10.0
HELDOUT_MIN_PCT = 1.0
AMBIGUOUS_BIC = 6.0
HELDOUT_TIE = 1.1  # held-out MSE ratio under which two training-tied candidates stay ambiguous
MIN_CONTRIBUTION = 0.3  # an effect smaller than this x the noise floor changes the gap by < 5 %: not named


def expected_group() -> tuple[str, ...]:
    """The physically expected effects, tried together per joint (Coulomb, viscous, rotor inertia)."""
    return tuple(n for n, k in EFFECTS.items() if k.EXPECTED)


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
    p, se = t.params()
    why = t.kind.plausible(p, sc, total_mass_kg)
    if why:
        return why
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
        self.kinds = [k for k in EFFECTS.values() if not (torque_kind == "measured" and k.ON_COMMAND)]
        self.names = [k.NAME for k in self.kinds if k.SINGLE]
        self.couplings = list(couplings)
        # (name, joint) of the nominal plant's effects: a refinement (e.g. an asymmetric Coulomb level) may
        # refine an effect the nominal plant already carries, not only one the search named
        self.in_nominal = {(e.name, e.joint) for e in sel.lib.nominal.effects}
        self.log: list[dict] = []
        self._floors: dict = {}

    def joints_of(self, t: Term) -> list[int]:
        if t.direction is not None:
            return [int(v) for v in self.rb.act_idx[np.abs(t.direction) > 0]]
        if t.kind.ACTS_ON != "joint":
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

    def model_floor(self, selected: list[Term]) -> np.ndarray:
        """Noise floor (N*m per joint) of the residual the selected terms leave, over all blocks, within
        [the sensors' least floor, the floor that whitens the fits]. The whitening floor is the nominal
        model's, inflated by every effect not yet named (a Coulomb step at each reversal is high-frequency
        residual too: 20-50x the final floor on the bench spine's log), so a small effect (a Stribeck excess
        under a named Coulomb level) is judged against what is left once the named effects are in."""
        key = tuple((t.key, t.theta, t.param_index) for t in selected)
        if key not in self._floors:
            sel = self.sel
            fitted = sel.fit(selected).beta
            res = []
            for bi in range(len(sel.lib.blocks)):
                r = sel.base[bi].copy()
                beta = iter(fitted)  # the linear terms' coefficients, in the order of `selected`
                for t in selected:
                    col = sel.lib.column(t, bi)
                    r = r - (col if t.fixed else col * next(beta))
                res.append(r)
            f, _ = noise_floor(sel.lib.blocks, res)
            self._floors[key] = np.minimum(np.maximum(f, sel.least_floor), 1.0 / sel.w)
        return self._floors[key]

    def contribution(self, fit: Fit, terms: list[Term], selected: list[Term]) -> float:
        """RMS of the terms' fitted contribution on their most affected joint over all blocks, in noise
        floors of the residual the already selected terms leave (`model_floor`, also over all blocks). Not
        the held-out blocks alone: an effect that acts on some trials only (a torque limit the held-out
        trial's command rarely reaches, while a training trial's controller winds up against it) is as
        large as it is where it acts; the held-out improvement is checked on its own."""
        sel = self.sel
        blocks = range(len(sel.lib.blocks))
        lin = [t for t in fit.terms if not t.fixed]
        tot = None
        for t in terms:
            col = np.vstack([sel.lib.column(t, bi) for bi in blocks])
            if not t.fixed:
                col = col * fit.beta[lin.index(t)]
            tot = col if tot is None else tot + col
        return float(np.max(np.sqrt(np.mean(tot**2, axis=0)) / self.model_floor(selected)))

    def why_not(self, terms: list[Term], fit: Fit) -> str | None:
        for t in terms:
            why = plausible(t, self.scale[t.joint], self.mass)
            if why:
                return f"{t.name}@{t.joint}: {why}"
        for k in dict.fromkeys(t.kind for t in fit.terms):
            why = k.model_problem(self, fit)
            if why:
                return why
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
        group = [n for n in expected_group() if n in self.names]
        for joint in self.rb.actuated:
            rest = [n for n in group if (n, joint) not in taken]
            if len(rest) >= 2:
                options.append([Term(n, joint) for n in rest])
            for k in self.kinds:
                options += k.joint_options(self, selected, taken, joint)
        for k in self.kinds:
            options += k.options(self, selected, taken)
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
            size = self.contribution(fit, new, selected)
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
                if why is None and t.kind.REFINES and (t.kind.REFINES, t.joint) not in \
                        {x.key for x in rest} | self.in_nominal:
                    why = f"refines a {t.kind.REFINES} no longer in the model"
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
                    "params": c[1][0].params()[0]} for c in rivals]
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


def expected_fit(sel: Selector) -> tuple[list[Term], Fit]:
    """The physically expected model fitted without selection: the expected group on every actuated joint
    (same data, weights and machinery), coefficients written into the terms."""
    terms = [Term(n, j) for j in sel.robot.actuated for n in expected_group()]
    fit = sel.fit(terms, with_se=True)
    for i, t in enumerate(terms):
        t.coef, t.se = float(fit.beta[i]), float(fit.se[i])
    return terms, fit
