"""Run the SPARC authors' released quadruped bound as they ship it, with their own `bard`, headless.

Why: the project's reference (`tests/reference/authors_bound.py`) re-expresses their controller with
pinocchio standing in for `bard`; this runs THEIR files with THEIR library, so the two can be compared.

Sources (read from local snapshots, extracted to a temporary folder, never copied into this repository):
  github.com/YueWang996/sparc, commit d9639f5, folder mujoco_simulation/ (main_robot.py,
  dog_controller_no_cpg.py, spine_impedance_controller.py, mujoco_interface.py, asset/);
  github.com/YueWang996/bard-pytorch-dynamics, commit ccfde3d (bard 0.2: the last commit with the
  `bard.core.dynamics/jacobian/kinematics` modules their code imports, 2025-10-14; the next, v0.3 of
  2026-03-07, removed them; sparc d9639f5 is of 2026-01-04).
sha256 of the files run (`git show <commit>:<path>`):
main_robot.py 70566aff5bd992462bb4758dd0e1798683b1caf85c85113d8e7ac0eea36f3f41,
dog_controller_no_cpg.py 8c028d2f23b57bbd2b173e8c95e3bd36e4961203bfcee54fb513ab6fc04d243b,
spine_impedance_controller.py 352d411da5a2c57449de8469cfb91dc48a22a9876435b489a8bf39290ff9b2ef,
mujoco_interface.py 14d996f2a1b45dbbfe7b006410cc3672c3afefc8ad652496b3e2f27bdb189a22,
asset/spined_dog.xml 75ac2f0460f40a8d8b024e8b73658a90c49057239d3beb5e87fbd9c11cc887d3,
asset/spined_dog_spine_dyn.urdf 20fee0c50b84b4ccca65662698c5313ebaa88005407bbdafa6e5fdfb2499629c;
bard bard/core/jacobian.py 7c5a6dc347b8e9c9dd574e05acd6024757ab037fd461e89c3faa90307eaba460,
kinematics.py fe2dfc2b2bdb6e750b1957e1a39fad786d35c5826e1cb1b96d374e3b821363f9,
dynamics.py 8594d729466396f6b7ce59db23afd19a6a6b2fd5561e1fde01c4f62f18353408.
Copyright (c) 2026 YueWang996, MIT licence: this script drives their code and changes a few of their
constants in the temporary copy (listed in PATCHES); it carries no code of theirs.

What is done to their code, and nothing else:
- `mujoco.viewer` is replaced by a headless stand-in: `launch_passive` returns a context manager whose
  `is_running()` turns false at the simulated duration, whose `sync()` (called after every `mj_step`)
  records the state, and whose `cam` takes any attribute;
- PATCHES: the two absolute asset paths, the leg `step_length`, and k_x in both spine stiffness vectors;
- their MJCF with its mesh assets and mesh geoms removed when a mesh file is missing from the snapshot
  (the meshes are visual: only the four foot spheres collide);
- `DogController.compute_torques` is wrapped (calls the original unchanged) to count control calls and
  keep the states and spine torques of the first calls for comparison with the pinocchio reference.

Usage (orchestrator, any Python >= 3.11 with git on PATH):
  python tests/reference/run_authors_released.py --sparc /work/.mirror/YueWang996+sparc/repo \
      --bard /work/.mirror/YueWang996+bard-pytorch-dynamics/repo --venv /tmp/authors-venv \
      --case 0.08:800 --case 0.12:800 --duration 20 --out /tmp/authors-released.json
`--compare` (orchestrator in the project's venv, pinocchio) also sets their run against the project's
pinocchio reference, `tests/reference/authors_bound.py`: the reference's spine law on the spine states
their run recorded (Jacobian and J̇q̇ taken LOCAL and rotated once, as the reference; and rotated twice:
LOCAL_WORLD_ALIGNED, then R_rel), and the reference's whole run from their start pose (see
`authors_bound.START_PHASE_OFFSETS`, its default since 2026-12-02) against their trajectory.
The venv needs torch, mujoco, numpy, scipy, lxml, pyyaml (bard's own dependencies); bard itself is put on
PYTHONPATH from the extracted commit (its pyproject installs only the top package, without `bard.core`).
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import math
import os
import subprocess
import sys
import tempfile
import types
import xml.etree.ElementTree as ET
from pathlib import Path

SPARC_COMMIT = "d9639f5"
BARD_COMMIT = "ccfde3d"
SIM_DIR = "mujoco_simulation"
THEIR_ASSET_PREFIX = "/Users/justin/PycharmProjects/spine-sim/asset/"  # main_robot.py's hard-coded paths
RELEASED_STEP_LENGTH_M = 0.12
RELEASED_KX = 800.0
RECORD_CALLS = 400  # control calls whose state and spine torque are kept (~2.2 s at their ~182 Hz)
SPINE_JOINTS = ("joint_hind_spine", "joint_front_spine", "joint_front_body")


def patches(step_length_m: float, k_x: float, asset_dir: Path) -> list[tuple[str, str, str, int]]:
    """(file, old, new, expected count) applied to the temporary copy; each must match exactly."""
    kx = f"np.array([{RELEASED_KX}, 2000.0, 15.0])"
    return [
        ("main_robot.py", THEIR_ASSET_PREFIX, f"{asset_dir}/", 2),
        ("main_robot.py", kx, f"np.array([{float(k_x)!r}, 2000.0, 15.0])", 2),
        ("dog_controller_no_cpg.py", f"step_length={RELEASED_STEP_LENGTH_M},",
         f"step_length={float(step_length_m)!r},", 1),
    ]


def apply_patches(sim_dir: Path, edits: list[tuple[str, str, str, int]]) -> None:
    for name, old, new, count in edits:
        path = sim_dir / name
        text = path.read_text()
        found = text.count(old)
        if found != count:
            raise SystemExit(f"patch anchor {old!r} found {found} times in {name}, expected {count}")
        path.write_text(text.replace(old, new))


def extract(repo: Path, commit: str, dest: Path, subdir: str | None = None) -> list[str]:
    """Write the files of one commit (optionally one folder) into dest, blob by blob: a partial snapshot
    lacks some large blobs (`git archive` then fails). Returns the paths whose blob is absent."""
    cmd = ["git", "-C", str(repo), "ls-tree", "-r", "-z", commit] + ([subdir] if subdir else [])
    listing = subprocess.run(cmd, capture_output=True, check=True).stdout.decode()
    absent = []
    for entry in filter(None, listing.split("\0")):
        meta, path = entry.split("\t", 1)
        _, kind, blob = meta.split()
        if kind != "blob":
            continue
        got = subprocess.run(["git", "-C", str(repo), "cat-file", "blob", blob], capture_output=True)
        if got.returncode != 0:
            absent.append(path)
            continue
        target = dest / path
        target.parent.mkdir(parents=True, exist_ok=True)
        target.write_bytes(got.stdout)
    return absent


def strip_missing_meshes(mjcf: Path) -> list[str]:
    """Drop mesh assets and mesh geoms if any mesh file is absent or a placeholder; returns the absent
    files (empty: the MJCF is left as released)."""
    root = ET.parse(mjcf).getroot()
    comp = root.find("compiler")
    meshdir = mjcf.parent / (comp.get("meshdir", "") if comp is not None else "")
    missing = []
    for asset in root.iter("asset"):
        for mesh in asset.findall("mesh"):
            f = meshdir / mesh.get("file", "")
            if not f.is_file() or f.stat().st_size < 1024:
                missing.append(mesh.get("file", ""))
    if not missing:
        return []
    _project_on_path()
    from tests.reference.authors_bound import strip_meshes

    strip_meshes(root)
    ET.ElementTree(root).write(mjcf)
    return sorted(set(missing))


# ----------------------------------------------------------------------------------- driver (their venv)

def _rpy_zyx(w: float, x: float, y: float, z: float) -> tuple[float, float, float]:
    roll = math.atan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
    pitch = math.asin(max(-1.0, min(1.0, 2 * (w * y - z * x))))
    yaw = math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
    return roll, pitch, yaw


def _driver(sim_dir: Path, duration_s: float, out: Path) -> None:
    """Run their main() headless in this process and write the record."""
    import mujoco
    import numpy as np

    rec: dict = {"t": [], "x": [], "y": [], "z": [], "pitch": [], "roll": [], "yaw": [], "front_pitch": []}
    calls: list[float] = []
    probes: list[dict] = []
    end: dict = {}

    class Viewer:
        def __init__(self, model, data) -> None:
            self.m, self.d = model, data
            self.cam = types.SimpleNamespace()
            free = [j for j in range(model.njnt) if model.jnt_type[j] == mujoco.mjtJoint.mjJNT_FREE]
            self.qadr = int(model.jnt_qposadr[free[0]])
            base = int(model.jnt_bodyid[free[0]])
            self.base_body = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, base)
            self.front = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, "front_body")
            end["base_body"] = self.base_body
            end["qpos0"] = [float(v) for v in data.qpos]
            end["qvel0"] = [float(v) for v in data.qvel]
            end["ctrl0"] = [float(v) for v in data.ctrl]

        def __enter__(self):
            return self

        def __exit__(self, exc_type, exc, tb) -> bool:
            end["t_end_s"] = float(self.d.time)
            end["exception"] = None if exc is None else f"{exc_type.__name__}: {exc}"
            return False

        def is_running(self) -> bool:
            return self.d.time < duration_s - 1e-9

        def sync(self) -> None:
            q = self.d.qpos[self.qadr:self.qadr + 7]
            roll, pitch, yaw = _rpy_zyx(*q[3:7])
            # front body: xquat is one step behind qpos; good enough for a 1 rad threshold
            _, fpitch, _ = _rpy_zyx(*self.d.xquat[self.front])
            for k, v in zip(("t", "x", "y", "z", "pitch", "roll", "yaw", "front_pitch"),
                            (self.d.time, q[0], q[1], q[2], pitch, roll, yaw, fpitch), strict=True):
                rec[k].append(float(v))

    viewer_mod = types.ModuleType("mujoco.viewer")
    viewer_mod.launch_passive = lambda model, data, **_: Viewer(model, data)
    sys.modules["mujoco.viewer"] = viewer_mod
    mujoco.viewer = viewer_mod

    sys.path.insert(0, str(sim_dir))
    os.chdir(sim_dir)
    import dog_controller_no_cpg as dcn  # their module, from the temporary copy

    original = dcn.DogController.compute_torques

    def counted(self, time, q_full, v_full, q_legs, v_legs):
        tau, q_des = original(self, time, q_full, v_full, q_legs, v_legs)
        calls.append(float(time))
        if len(probes) < RECORD_CALLS:
            sc = self.spine_controller
            probes.append({"t": float(time), "q_full": [float(a) for a in q_full],
                           "v_full": [float(a) for a in v_full], "tau_spine": [float(a) for a in tau[4:7]],
                           "kp": [float(a) for a in np.diag(sc.kp)], "kd": [float(a) for a in np.diag(sc.kd)],
                           "x_des": [float(a) for a in sc.x_des]})
        return tau, q_des

    dcn.DogController.compute_torques = counted
    import main_robot

    log = io.StringIO()
    with contextlib.redirect_stdout(log):
        main_robot.main()
    out.write_text(json.dumps({"record": rec, "calls": calls, "probes": probes, "end": end,
                               "stdout": log.getvalue(),
                               "versions": {"mujoco": mujoco.__version__, "numpy": np.__version__,
                                            "torch": __import__("torch").__version__,
                                            "python": sys.version.split()[0]}}))


# ------------------------------------------------------------------------------------------- measuring

def measure(raw: dict, duration_s: float) -> dict:
    """Fate and speeds from a driver record. Fall (theirs): |roll| or |pitch| of the hind body beyond
    90 deg at a control call (their RuntimeError). Fall (project, bound.python_loop.fall_reason on this robot,
    whose only colliding geoms are the feet): |hind pitch| or |front pitch| beyond 1 rad, |roll| beyond
    0.8 rad."""
    r = raw["record"]
    t, x = r["t"], r["x"]
    proj = next((t[i] for i in range(len(t)) if abs(r["pitch"][i]) > 1.0 or abs(r["front_pitch"][i]) > 1.0
                 or abs(r["roll"][i]) > 0.8), None)
    exc = raw["end"].get("exception")
    stdout = raw["stdout"]
    their_fall = raw["end"]["t_end_s"] if (exc or "terminated early" in stdout) else None

    def speed(t0: float, t1: float) -> float | None:
        idx = [i for i in range(len(t)) if t0 <= t[i] <= t1]
        if len(idx) < 2 or t[idx[-1]] - t[idx[0]] < 1.0:
            return None
        return (x[idx[-1]] - x[idx[0]]) / (t[idx[-1]] - t[idx[0]])

    calls = raw["calls"]
    return {
        "t_end_s": raw["end"]["t_end_s"], "fall_theirs_s": their_fall, "fall_project_rule_s": proj,
        "speed_whole_m_s": speed(0.0, duration_s), "speed_4s_end_m_s": speed(4.0, duration_s),
        "x_end_m": x[-1] if x else None, "y_end_m": r["y"][-1] if x else None,
        "yaw_end_rad": r["yaw"][-1] if x else None,
        "control_calls": len(calls), "control_rate_hz": len(calls) / calls[-1] if calls else None,
        "first_call_s": calls[0] if calls else None,
        "calibration": next((ln.strip() for ln in stdout.splitlines() if "Calibration" in ln), None),
        "adapt_queued": stdout.count("[Adapt]"), "freq_updates": stdout.count("[Cycle Sync]"),
        "their_exit": exc, "base_body": raw["end"].get("base_body"),
    }


def run_case(sparc: Path, bard_src: Path, venv: Path, step_length_m: float, k_x: float, duration_s: float,
             work: Path) -> dict:
    case_dir = work / f"L{step_length_m}_kx{k_x}"
    case_dir.mkdir(parents=True)
    absent = extract(sparc, SPARC_COMMIT, case_dir, SIM_DIR)
    sim = case_dir / SIM_DIR
    stripped = strip_missing_meshes(sim / "asset" / "spined_dog.xml")
    edits = patches(step_length_m, k_x, sim / "asset")
    apply_patches(sim, edits)
    out = case_dir / "record.json"
    env = dict(os.environ, PYTHONPATH=str(bard_src), PYTHONDONTWRITEBYTECODE="1")
    cmd = ["nice", "-n", "10", str(venv / "bin" / "python"), str(Path(__file__).resolve()), "--driver",
           str(sim), "--duration", str(duration_s), "--out", str(out)]
    p = subprocess.run(cmd, env=env, capture_output=True, text=True, check=False)
    if p.returncode != 0:
        raise SystemExit(f"their run failed (L {step_length_m}, k_x {k_x}):\n{p.stderr[-3000:]}")
    raw = json.loads(out.read_text())
    res = {"step_length_m": step_length_m, "k_x": k_x, "duration_s": duration_s,
           "patches": [{"file": f, "old": o, "new": n} for f, o, n, _ in edits],
           "absent_from_snapshot": absent, "meshes_stripped": stripped, "versions": raw["versions"],
           **measure(raw, duration_s)}
    res["initial"] = {k: raw["end"][k] for k in ("qpos0", "qvel0", "ctrl0")}
    res["probes"] = raw["probes"]
    res["series"] = raw["record"]
    return res


# ---------------------------------------------------------------------- against the pinocchio reference

def compare_spine_law(probes: list[dict]) -> dict:
    """Largest |tau_theirs - tau_reference| (N m) over the recorded calls, for the reference law as it is
    (LOCAL, rotated once by R_rel) and with its Jacobian and spatial acceleration LOCAL_WORLD_ALIGNED
    (then rotated by R_rel: twice)."""
    import numpy as np
    import pinocchio as pin

    from tests.reference.authors_bound import AuthorsSpineLaw, load_model

    model = load_model()
    once, twice = AuthorsSpineLaw(model), AuthorsSpineLaw(model)
    twice.pin = types.SimpleNamespace(**{k: getattr(pin, k) for k in dir(pin) if not k.startswith("__")})
    twice.pin.ReferenceFrame = types.SimpleNamespace(LOCAL=pin.ReferenceFrame.LOCAL_WORLD_ALIGNED)
    d_once, d_twice, mag = [], [], []
    for pr in probes:
        q, v, tau = np.array(pr["q_full"]), np.array(pr["v_full"]), np.array(pr["tau_spine"])
        for law in (once, twice):
            law.kp, law.kd, law.x_des = np.array(pr["kp"]), np.array(pr["kd"]), np.array(pr["x_des"])
        d_once.append(float(np.abs(tau - once.torque(q, v)).max()))
        d_twice.append(float(np.abs(tau - twice.torque(q, v)).max()))
        mag.append(float(np.abs(tau).max()))
    return {"calls": len(probes), "t_last_s": probes[-1]["t"] if probes else None,
            "tau_max_nm": max(mag, default=None), "once_max_diff_nm": max(d_once, default=None),
            "once_median_diff_nm": float(np.median(d_once)) if d_once else None,
            "twice_max_diff_nm": max(d_twice, default=None),
            "twice_median_diff_nm": float(np.median(d_twice)) if d_twice else None}


def reference_run(step_length_m: float, k_x: float, duration_s: float, released_start: bool):
    """The pinocchio reference's run; released_start: legs posed as their code poses them (the reference's
    default), else at the bound's offsets (the reference's start before 2026-12-02)."""
    import tests.reference.authors_bound as ab

    offsets = ab.START_PHASE_OFFSETS if released_start else ab.PHASE_OFFSETS
    return ab.run_authors_bound(ab.AuthorsBoundConfig(step_length_m=step_length_m, k_x=k_x,
                                                      duration_s=duration_s, start_offsets=offsets))


def compare_trajectory(series: dict, ref) -> dict:
    """Largest |theirs - reference| of hind-body x and pitch up to 2, 4 and 20 s (their record is the
    state after each step, the reference's log the state before it)."""
    import numpy as np

    t = np.array(series["t"])
    n = min(len(t), len(ref.t) - 1)
    ex = np.abs(np.array(series["x"])[:n] - ref.x[1:n + 1])
    ep = np.abs(np.array(series["pitch"])[:n] - ref.pitch[1:n + 1])
    out = {}
    for t1 in (2.0, 4.0, 20.0):
        w = t[:n] <= t1
        if w.any():
            out[f"x_max_diff_m_to_{t1:g}s"] = float(ex[w].max())
            out[f"pitch_max_diff_rad_to_{t1:g}s"] = float(ep[w].max())
    return out


def _project_on_path() -> None:
    root = str(Path(__file__).resolve().parents[2])  # the project checkout, for tests.reference
    if root not in sys.path:
        sys.path.insert(0, root)


def compare(r: dict) -> dict:
    _project_on_path()
    out: dict = {"spine_law": compare_spine_law(r["probes"])}
    for label, released in (("reference_bound_start", False), ("reference_released_start", True)):
        ref = reference_run(r["step_length_m"], r["k_x"], r["duration_s"], released)
        speeds = {"speed_4s_end_m_s": ref.speed_m_s(4.0), "speed_whole_m_s": ref.speed_m_s(0.0)}
        speeds = {k: None if math.isnan(v) else v for k, v in speeds.items()}
        out[label] = {"fall_s": ref.fall_time_s, **speeds, **compare_trajectory(r["series"], ref)}
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--sparc", type=Path, help="git dir of the sparc snapshot")
    ap.add_argument("--bard", type=Path, help="git dir of the bard-pytorch-dynamics snapshot")
    ap.add_argument("--venv", type=Path, help="venv with torch + mujoco + numpy + scipy + lxml + pyyaml")
    ap.add_argument("--case", action="append", default=[], help="L:k_x, e.g. 0.08:800 (repeatable)")
    ap.add_argument("--duration", type=float, default=20.0, help="simulated seconds")
    ap.add_argument("--out", type=Path, required=True, help="JSON written here")
    ap.add_argument("--series", action="store_true", help="keep per-step series and probes in the JSON")
    ap.add_argument("--compare", action="store_true",
                    help="also run the pinocchio reference (needs the project's venv) and compare")
    ap.add_argument("--driver", type=Path, help=argparse.SUPPRESS)
    a = ap.parse_args(argv)
    if a.driver:
        _driver(a.driver, a.duration, a.out)
        return 0
    for name in ("sparc", "bard", "venv"):
        if getattr(a, name) is None or not getattr(a, name).exists():
            print(f"error: --{name} missing or not found: {getattr(a, name)}", file=sys.stderr)
            return 2
    try:
        cases = [tuple(float(v) for v in c.split(":")) for c in a.case or ["0.08:800"]]
        if any(len(c) != 2 for c in cases):
            raise ValueError
    except ValueError:
        print(f"error: --case must be L:k_x, got {a.case}", file=sys.stderr)
        return 2
    results = []
    with tempfile.TemporaryDirectory(prefix="authors-released-") as tmp:
        work = Path(tmp)
        extract(a.bard, BARD_COMMIT, work / "bard")
        for step_length_m, k_x in cases:
            r = run_case(a.sparc, work / "bard", a.venv, step_length_m, k_x, a.duration, work)
            if a.compare:
                r["compare"] = compare(r)
            if not a.series:
                r.pop("series")
                r.pop("probes")
            results.append(r)
            shown = {k: v for k, v in r.items() if k not in ("series", "probes", "patches", "initial")}
            print(json.dumps(shown))
    a.out.write_text(json.dumps({"sparc_commit": SPARC_COMMIT, "bard_commit": BARD_COMMIT,
                                 "results": results}, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
