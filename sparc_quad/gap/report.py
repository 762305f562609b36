"""report.md and its PNG plots beside it."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from sparc_quad.effects import kind
from sparc_quad.gap.regimes import REGIMES


def _fmt(x: float | None) -> str:
    return "not replayed" if x is None else f"{x:.4g}"


def plot_regimes(path: Path, report: dict, robot) -> None:
    regs = report["localisation"]["regimes"]
    fig, ax = plt.subplots(figsize=(8, 3.5))
    names = ("all_samples", *REGIMES)
    width = 0.8 / len(names)
    x = np.arange(robot.nv)
    overall = {d["joint"]: d["rms_over_floor"] for d in report["localisation"]["joints"]}
    for i, name in enumerate(names):
        vals = [overall[j] if name == "all_samples" else
                next((r["rms_over_floor"] for r in regs if r["joint"] == j and r["regime"] == name), 0.0)
                for j in robot.joints]
        ax.bar(x + (i - len(names) / 2 + 0.5) * width, vals, width, label=name,
               color="0.6" if name == "all_samples" else None)
    ax.axhline(1.0, color="k", lw=0.8, ls="--", label="noise floor")
    ax.set_xticks(x, robot.joints)
    ax.set_yscale("log")
    ax.set_ylabel("RMS residual / noise floor")
    ax.set_title("Nominal-model inverse-dynamics residual by regime")
    ax.legend(fontsize=7, ncol=3)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_residual_time(path: Path, report: dict, robot, blocks, res0) -> tuple[str, int]:
    """The residual over time of the block holding the largest-residual span (the spans the report names
    are drawn where they are), else of the first block; (its trial's name, spans drawn)."""
    fig, axes = plt.subplots(robot.nv, 1, figsize=(9, 1.8 * robot.nv + 0.6), sharex=False, squeeze=False)
    named = report["localisation"]["spans"]
    pick = 0
    for s in named:  # largest first
        hit = [i for i, blk in enumerate(blocks) if blk.trial.name == s["trial"] and len(blk.idx)
               and blk.trial.t[blk.idx][0] <= s["t0_s"] <= blk.trial.t[blk.idx][-1]]
        if hit:
            pick = hit[0]
            break
    b, r = blocks[pick], res0[pick]
    t = b.trial.t[b.idx]
    spans = [s for s in named if s["trial"] == b.trial.name and t[0] <= s["t0_s"] <= t[-1]]
    for v, j in enumerate(robot.joints):
        ax = axes[v, 0]
        ax.plot(t, r[:, v], lw=0.7)
        for s in spans:
            if s["joint"] == j:
                ax.axvspan(s["t0_s"], s["t1_s"], color="r", alpha=0.15)
        ax.set_ylabel(f"{j} N*m")
    shaded = f"shaded: the {len(spans)} largest-residual span(s) in it" if spans else \
        "none of the largest-residual spans falls in this trial"
    axes[-1, 0].set_xlabel(f"t (s), trial {b.trial.name}; {shaded}")
    fig.suptitle("Nominal-model inverse-dynamics residual")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return b.trial.name, len(spans)


def plot_overlay_residual(path: Path, robot, ho_blocks, res_b, res_a, floor) -> None:
    fig, axes = plt.subplots(robot.nv, 1, figsize=(9, 1.8 * robot.nv + 0.6), squeeze=False)
    b = ho_blocks[0]
    t = b.trial.t[b.idx]
    for v, j in enumerate(robot.joints):
        ax = axes[v, 0]
        ax.plot(t, res_b[0][:, v], lw=0.7, label="before (nominal)")
        ax.plot(t, res_a[0][:, v], lw=0.7, label="after (plant.json)")
        ax.axhspan(-floor[v], floor[v], color="g", alpha=0.15, label="+- noise floor")
        ax.set_ylabel(f"{j} N*m")
    axes[0, 0].legend(fontsize=7, loc="upper right")
    axes[-1, 0].set_xlabel(f"t (s), held-out block {b.trial.name}")
    fig.suptitle("Held-out inverse-dynamics residual before and after")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_overlay_replay(path: Path, robot, ho_blocks, rep_b, rep_a) -> None:
    fig, axes = plt.subplots(robot.nv, 1, figsize=(9, 1.8 * robot.nv + 0.6), squeeze=False)
    tr = ho_blocks[0].trial
    n = min(len(tr.t), round(2.0 * tr.rate_hz))
    for v, j in enumerate(robot.joints):
        ax = axes[v, 0]
        ax.plot(tr.t[:n], rep_b[0]["q_meas"][:n, v], "k", lw=1.0, label="measured")
        ax.plot(tr.t[:n], rep_b[0]["q_sim"][:n, v], lw=0.8, label="replay before")
        ax.plot(tr.t[:n], rep_a[0]["q_sim"][:n, v], lw=0.8, label="replay after")
        ax.set_ylabel(f"{j} rad")
    axes[0, 0].legend(fontsize=7, loc="upper right")
    axes[-1, 0].set_xlabel("t (s): windowed replay from the measured state, held-out block")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def markdown(report: dict, robot) -> str:
    L = ["# Sim-vs-measured gap report\n", f"**Verdict: `{report['verdict']}`**\n",
         f"Robot `{report['robot']['urdf']}`, joints {', '.join(robot.joints)}; "
         f"noise floor by {report['noise_floor_method']}.\n",
         "## Gap (held-out data)\n",
         "| joint | noise floor N*m | ID residual before | after | after / floor "
         "| replay before rad | after |",
         "|---|---|---|---|---|---|---|"]
    gb, ga = report["gap_before"], report["gap_after"]
    for j in robot.joints:
        L.append(f"| {j} | {_fmt(report['noise_floor'][j])} | {_fmt(gb['id_residual_rms_nm'][j])} | "
                 f"{_fmt(ga['id_residual_rms_nm'][j])} | {_fmt(report['gap_after_over_floor'][j])} | "
                 f"{_fmt(gb['replay_rms_rad'][j])} | {_fmt(ga['replay_rms_rad'][j])} |")
    L += ["", f"The gap counts as closed when every joint's held-out residual is within "
              f"{report['gap_closed_factor']}x its noise floor.\n", "## Named effects (selection order)\n"]
    if report["effects"]:
        L += ["| effect | joint | parameters (SI) | dBIC | held-out improvement % |", "|---|---|---|---|---|"]
        for e in report["effects"]:
            ps = kind(e["name"]).format_params(e["params"])
            L.append(f"| {e['name']} | {e['joint']} | {ps} | {_fmt(e['delta_bic'])} | "
                     f"{_fmt(e['heldout_improvement_pct'])} |")
    else:
        L.append("None passed (dBIC, held-out and plausibility checks).")
    if report["ambiguous"]:
        L += ["", "## Ambiguous (the data cannot separate these)\n"]
        for a in report["ambiguous"]:
            alts = "; ".join(f"{x['name']} on {x['joint']} (dBIC {x['delta_bic_vs_best']:+.1f})"
                             for x in a["alternatives"])
            L.append(f"- {a['best']['name']} on {a['best']['joint']} vs {alts}")
    L += ["", "## Where the nominal model disagrees\n",
          "| joint | regime | RMS N*m | / floor | share of samples |",
          "|---|---|---|---|---|"]
    for r in report["localisation"]["regimes"][:10]:
        L.append(f"| {r['joint']} | {r['regime']} | {_fmt(r['rms_nm'])} | {_fmt(r['rms_over_floor'])} | "
                 f"{_fmt(r['fraction_of_samples'])} |")
    L += ["", "Largest spans: " + "; ".join(f"{s['trial']} {s['t0_s']:.2f}-{s['t1_s']:.2f} s on {s['joint']} "
                                           f"({s['rms_over_floor']:.1f}x floor)"
                                           for s in report["localisation"]["spans"][:5]), ""]
    L += ["![residual by regime](residual_by_regime.png)", "", "![residual](residual_time.png)", "",
          "![before/after residual](overlay_residual.png)", "",
          "![before/after replay](overlay_replay.png)", "",
          "The plant model with the named effects is `plant.json` (load with `--plant plant.json`)."]
    return "\n".join(L) + "\n"


def write(out: Path, report, robot, blocks, res0, ho_blocks, res_b, res_a, rep_b, rep_a, floor) -> None:
    plot_regimes(out / "residual_by_regime.png", report, robot)
    plot_residual_time(out / "residual_time.png", report, robot, blocks, res0)
    plot_overlay_residual(out / "overlay_residual.png", robot, ho_blocks, res_b, res_a, floor)
    plot_overlay_replay(out / "overlay_replay.png", robot, ho_blocks, rep_b, rep_a)
    (out / "report.md").write_text(markdown(report, robot))
