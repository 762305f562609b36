"""Run the SPARC authors' speed-commanded Raibert bound (gait C's source) as they wrote it, headless, with
their own `bard`, and set it beside the project's port (`sparc_quad/gaits/authors_raibert.py`).

Why: gait C re-expresses their controller; this runs THEIR files, so the port can be checked against them
call by call over the first seconds and over a 20 s run, as `run_authors_released.py` does for gait A.

Sources (extracted to a folder outside this repository, never copied into it):
  github.com/YueWang996/sparc (MIT, Copyright (c) 2026 YueWang996), folder mujoco_simulation/:
    main_robot_raibert.py, dog_controller_raibert.py, spine_impedance_controller.py at
    9aee563d6d07dffe7dd121e0d931e959667e18a7; mujoco_interface.py at d9639f5 (the only version stored; every
    call the script makes is in it); asset/spined_dog.xml and asset/spined_dog_locked_spine.xml at
    1c8013a8108e3a3875950d41b4d759df690ad453; asset/spined_dog_spine_dyn.urdf at
    a7fca48094015d3fdac251e6ecb9d04e4744802e (the first with the `spine_end_effector` frame their spine law
    regulates). No fetchable snapshot holds these commits: the text was read from the search index
    (`read_file`, repo YueWang996/sparc, path, commit), each file's length checked against the stored one;
    the three assets were rebuilt from the d9639f5 snapshot plus the lines the stored text changes (same
    length). `--src` names the folder; every file is checked against these sha256 (of its UTF-8 bytes)
    before anything runs:
SOURCES:
  main_robot_raibert.py 483f91a5f27b2c56be497aa319a4b6e8f18e52911719ec1ffa86227ae7677fa4
  dog_controller_raibert.py 3d136e112b58e3566daf5b4f2507fb621164c892bbf654c1c1a8ad53151927a0
  spine_impedance_controller.py 9a7cfa36b337baacd7f56b22b8ce57bde824eec906efbcd5da622c91a18b765e
  mujoco_interface.py 14d996f2a1b45dbbfe7b006410cc3672c3afefc8ad652496b3e2f27bdb189a22
  asset/spined_dog.xml 6e2f75aabfda2af7261925d1970bcfc36f405bbe8ce8c61233e335f62a4cce9b
  asset/spined_dog_locked_spine.xml 6fabd2093825a65388f69897905e409b93f57c7ccee48260bf04721280a1bbef
  asset/spined_dog_spine_dyn.urdf 03cb7e9c48dc8f5c51c5d3398ed6aba5f8fe7cdbe8c70550147a9b827574c135
END
  github.com/YueWang996/bard-pytorch-dynamics (MIT), commit fd70dc4 (bard 0.4.3, 2026-03-28, the snapshot's
  newest): their spine law calls bard's Model/Data API (`build_model_from_urdf`, `create_data`,
  `update_kinematics`, `forward_kinematics`, `jacobian`, `rnea`, `crba`, `spatial_acceleration`), which
  exists from bard v0.3 (074efd9, 2026-03-07) on; `--bard-commit` picks another.
This script drives their code and changes a few of their constants in the temporary copy; it carries no
code of theirs.

What is done to their code, and nothing else:
- `mujoco.viewer` is replaced by a headless stand-in: `launch_passive` returns a context manager whose
  `is_running()` is always true (their `max_time` ends the run), whose `sync()` (called after every
  `mj_step`) records the state, and whose `cam` takes any attribute;
- PATCHES (main_robot_raibert.py only): `DESIRED_VELOCITY = 1.3` -> the case's speed; `sim.run(max_time=20.0)`
  -> the run's duration; for the locked case, `model_path` -> `spined_dog_locked_spine.xml` (their own
  commented-out line names it). Nothing else: the locked case keeps their spine start (-0.6, 1.2, -0.6),
  which the model's equalities pull to (-0.85, 1.5, -0.85), and their spine law still drives the three
  locked joints' motors, as their script would;
- both MJCFs lose their mesh assets and mesh geoms (the STL files are not extracted; every mesh geom is in
  class `visual`, density 0, contype 0, and every body has an explicit inertial: only the four foot
  spheres collide);
- `DogControllerRaibert.compute_torques` is wrapped (calls the original unchanged) to count the calls and
  keep the inputs and the 11 torques of those in the first `--record` seconds.

Usage (orchestrator in the project's venv):
  .venv/bin/python tests/reference/run_authors_raibert.py --src /tmp/authors-raibert-src \
      --bard /work/.mirror/YueWang996+bard-pytorch-dynamics/repo --venv /tmp/authors-venv \
      --case 0.9:spine --case 0.9:locked --duration 20 --port --out /tmp/authors-raibert.json
  `--port` also runs gait C (the project's scenario, MuJoCo, same speed, `--spine rigid` for locked) and
  compares; `--fixture PATH` writes the first-seconds record of their run (per control call) for
  tests/integration/sim/test_authors_raibert_reference.py. The venv needs torch, mujoco, numpy (bard's
  other imports: lxml, pyyaml, scipy); bard goes on PYTHONPATH from the extracted commit.
"""

from __future__ import annotations

import argparse
import contextlib
import hashlib
import io
import json
import os
import shutil
import subprocess
import sys
import tempfile
import types
import xml.etree.ElementTree as ET
from pathlib import Path

try:  # shared with gait A's runner: as a module of tests.reference, or as a script beside it
    from tests.reference.run_authors_released import _project_on_path, _rpy_zyx, apply_patches
except ImportError:
    from run_authors_released import _project_on_path, _rpy_zyx, apply_patches

SIM_DIR = "mujoco_simulation"
BARD_COMMIT = "fd70dc4"
RECORD_S = 2.0  # per-call records kept for the first seconds
WINDOW_S = (5.0, 20.0)  # mean speed window
MAIN = "main_robot_raibert.py"
LEGS = ("HL", "HR", "FL", "FR")
# their full_tau order: HL hip, knee, HR hip, knee, 3 spine, FL hip, knee, FR hip, knee
TAU_LEG_INDEX = {"HL": (0, 1), "HR": (2, 3), "FL": (7, 8), "FR": (9, 10)}
TAU_SPINE_INDEX = (4, 5, 6)


def sources() -> dict[str, str]:
    """path -> sha256, from this module's docstring (one table, one truth)."""
    doc = __doc__ or ""
    body = doc.split("SOURCES:\n", 1)[1].split("\nEND", 1)[0]
    return dict(line.split() for line in body.strip().splitlines())


def patches(speed_m_s: float, locked: bool, duration_s: float) -> list[tuple[str, str, str, int]]:
    """(file, old, new, expected count) applied to the temporary copy; each must match exactly."""
    out = [(MAIN, "DESIRED_VELOCITY = 1.3\n", f"DESIRED_VELOCITY = {float(speed_m_s)!r}\n", 1),
           (MAIN, "sim.run(max_time=20.0)", f"sim.run(max_time={float(duration_s)!r})", 1)]
    if locked:
        out.append((MAIN, '/ "asset" / "spined_dog.xml")', '/ "asset" / "spined_dog_locked_spine.xml")', 1))
    return out




def copy_sources(src: Path, dest: Path) -> dict[str, str]:
    """Copy the checked files of `src`/mujoco_simulation into dest; refuse any whose sha256 differs."""
    got = {}
    for rel, sha in sources().items():
        f = src / SIM_DIR / rel
        if not f.is_file():
            raise SystemExit(f"missing from --src: {SIM_DIR}/{rel}")
        digest = hashlib.sha256(f.read_bytes()).hexdigest()
        if digest != sha:
            raise SystemExit(f"{SIM_DIR}/{rel}: sha256 {digest}, expected {sha}")
        (dest / rel).parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(f, dest / rel)
        got[rel] = digest
    return got


def strip_meshes(mjcf: Path) -> None:
    root = ET.parse(mjcf).getroot()
    for asset in root.iter("asset"):
        for mesh in list(asset.findall("mesh")):
            asset.remove(mesh)
    for parent in root.iter():
        for geom in list(parent.findall("geom")):
            if geom.get("type") == "mesh":
                parent.remove(geom)
    ET.ElementTree(root).write(mjcf)


def extract_bard(repo: Path, commit: str, dest: Path) -> None:
    """bard/ of one commit into dest (blob by blob: the snapshot lacks some large non-code blobs)."""
    listing = subprocess.run(["git", "-C", str(repo), "ls-tree", "-r", "-z", commit, "bard"],
                             capture_output=True, check=True).stdout.decode()
    for entry in filter(None, listing.split("\0")):
        meta, path = entry.split("\t", 1)
        blob = meta.split()[2]
        data = subprocess.run(["git", "-C", str(repo), "cat-file", "blob", blob], capture_output=True,
                              check=True).stdout
        (dest / path).parent.mkdir(parents=True, exist_ok=True)
        (dest / path).write_bytes(data)


# ----------------------------------------------------------------------------------- driver (their venv)



def _driver(sim_dir: Path, record_s: float, out: Path) -> None:
    """Run their main() headless in this process and write the record."""
    import mujoco
    import numpy as np

    rec: dict = {k: [] for k in ("t", "x", "y", "z", "pitch", "roll", "yaw", "q2", "q3", "q4")}
    calls: list[float] = []
    probes: list[dict] = []
    end: dict = {}

    class Viewer:
        def __init__(self, model, data) -> None:
            self.m, self.d = model, data
            self.cam = types.SimpleNamespace()
            jid = [mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, n)
                   for n in ("joint_hind_spine", "joint_front_spine", "joint_front_body")]
            self.spine_adr = [int(model.jnt_qposadr[j]) for j in jid]
            end["qpos0"] = [float(v) for v in data.qpos]

        def __enter__(self):
            return self

        def __exit__(self, exc_type, exc, tb) -> bool:
            end["t_end_s"] = float(self.d.time)
            end["exception"] = None if exc is None else f"{exc_type.__name__}: {exc}"
            return False

        def is_running(self) -> bool:
            return True

        def sync(self) -> None:
            q = self.d.qpos
            roll, pitch, yaw = _rpy_zyx(*q[3:7])
            row = (self.d.time, q[0], q[1], q[2], pitch, roll, yaw, *(q[a] for a in self.spine_adr))
            for k, v in zip(rec, row, strict=True):
                rec[k].append(float(v))

    viewer_mod = types.ModuleType("mujoco.viewer")
    viewer_mod.launch_passive = lambda model, data, **_: Viewer(model, data)
    sys.modules["mujoco.viewer"] = viewer_mod
    mujoco.viewer = viewer_mod

    sys.path.insert(0, str(sim_dir))
    os.chdir(sim_dir)
    import dog_controller_raibert as dcr  # their module, from the temporary copy

    original = dcr.DogControllerRaibert.compute_torques

    def counted(self, time, q_full, v_full, q_legs, v_legs, v_front, v_hind, pitch=0.0):
        full_tau, legs = original(self, time, q_full, v_full, q_legs, v_legs, v_front, v_hind, pitch=pitch)
        calls.append(float(time))
        if time < record_s:
            probes.append({"t": float(time), "q_full": [float(a) for a in q_full],
                           "v_full": [float(a) for a in v_full], "q_legs": [float(a) for a in q_legs],
                           "v_legs": [float(a) for a in v_legs], "v_front_x": float(v_front[0]),
                           "v_hind_x": float(v_hind[0]), "pitch": float(pitch),
                           "v_cmd_filtered": float(self.v_cmd_filtered),
                           "tau": [float(a) for a in full_tau]})
        return full_tau, legs

    dcr.DogControllerRaibert.compute_torques = counted
    import main_robot_raibert

    log = io.StringIO()
    with contextlib.redirect_stdout(log):
        main_robot_raibert.main()
    out.write_text(json.dumps({"record": rec, "calls": calls, "probes": probes, "end": end,
                               "stdout": log.getvalue()[-4000:],
                               "versions": {"mujoco": mujoco.__version__, "numpy": np.__version__,
                                            "torch": __import__("torch").__version__,
                                            "python": sys.version.split()[0]}}))


# ------------------------------------------------------------------------------------------- measuring

def _first(cond) -> float | None:
    return next((t for t, c in cond if c), None)


def summarize(t, x, pitch, pitch_front, roll, n_calls: int, duration_s: float) -> dict:
    """The same numbers from either run's per-step state (lists or arrays over time).
    fell: the project's rule (`sim.fall`: hind or front pitch beyond 1 rad, roll beyond 0.8 rad; only the
    feet collide on this model, so no body contact); their code has no fall test and runs on.
    gait frequency: the peak of the hind pitch's spectrum over the window (zero-padded x16, 1-8 Hz)."""
    import numpy as np

    t, x, pitch = np.asarray(t), np.asarray(x), np.asarray(pitch)
    fall = _first(zip(t, (np.abs(pitch) > 1.0) | (np.abs(np.asarray(pitch_front)) > 1.0)
                      | (np.abs(np.asarray(roll)) > 0.8), strict=True))
    w = (t >= WINDOW_S[0] - 1e-9) & (t <= min(WINDOW_S[1], duration_s) + 1e-9)
    speed = freq = None
    if w.sum() > 1000:
        tw, xw, pw = t[w], x[w], pitch[w]
        speed = float((xw[-1] - xw[0]) / (tw[-1] - tw[0]))
        dt = float(np.median(np.diff(tw)))
        sig = pw - pw.mean()
        n = 16 * len(sig)
        spec = np.abs(np.fft.rfft(sig * np.hanning(len(sig)), n))
        f = np.fft.rfftfreq(n, dt)
        band = (f >= 1.0) & (f <= 8.0)
        freq = float(f[band][np.argmax(spec[band])])
    return {"distance_m": float(x[-1] - x[0]), "speed_window_m_s": speed, "fell": fall is not None,
            "fall_s": None if fall is None else float(fall), "gait_frequency_hz": freq,
            "control_calls": int(n_calls), "t_end_s": float(t[-1])}


def measure(raw: dict, duration_s: float) -> dict:
    r = raw["record"]
    front = [p + a + b + c for p, a, b, c in zip(r["pitch"], r["q2"], r["q3"], r["q4"], strict=True)]
    out = summarize(r["t"], r["x"], r["pitch"], front, r["roll"], len(raw["calls"]), duration_s)
    out["first_call_s"] = raw["calls"][0] if raw["calls"] else None
    out["their_exit"] = raw["end"].get("exception")
    return out


def run_case(src: Path, bard_src: Path, venv: Path, speed: float, locked: bool, duration_s: float,
             record_s: float, work: Path) -> dict:
    label = f"{speed:g}_{'locked' if locked else 'spine'}"
    sim = work / label / SIM_DIR
    digests = copy_sources(src, sim)
    for xml in ("spined_dog.xml", "spined_dog_locked_spine.xml"):
        strip_meshes(sim / "asset" / xml)
    edits = patches(speed, locked, duration_s)
    apply_patches(sim, edits)
    out = work / label / "record.json"
    env = dict(os.environ, PYTHONPATH=str(bard_src), PYTHONDONTWRITEBYTECODE="1", OMP_NUM_THREADS="1")
    cmd = ["nice", "-n", "10", str(venv / "bin" / "python"), str(Path(__file__).resolve()), "--driver",
           str(sim), "--record", str(record_s), "--out", str(out)]
    p = subprocess.run(cmd, env=env, capture_output=True, text=True, check=False)
    if p.returncode != 0:
        raise SystemExit(f"their run failed ({label}):\n{p.stderr[-3000:]}")
    raw = json.loads(out.read_text())
    return {"speed_m_s": speed, "spine": "locked" if locked else "spine", "duration_s": duration_s,
            "patches": [{"file": f, "old": o, "new": n} for f, o, n, _ in edits], "sha256": digests,
            "versions": raw["versions"], **measure(raw, duration_s),
            "probes": raw["probes"], "series": raw["record"]}


# ------------------------------------------------------------------------------------ the project's port



def run_port(speed: float, locked: bool, duration_s: float):
    """Gait C through the project's scenario, as `sparc-quad bound --host spined-dog --gait authors-raibert
    --engine mujoco --speed V [--spine rigid]` runs it. Returns (series as column dict, metrics)."""
    import warnings

    _project_on_path()
    from sparc_quad import Scenario, bound_config
    from sparc_quad.bound.run import run_bound
    from sparc_quad.sim.bound_log import COLUMNS

    s = Scenario(host="spined-dog", gait="authors-raibert", engine="mujoco", speed=speed, duration=duration_s,
                 **({"spine": "rigid"} if locked else {}))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        res = run_bound(bound_config(s))
    cols = {c: res.series[:, i] for i, c in enumerate(COLUMNS)}
    return cols, res.metrics


def port_calls(cols: dict) -> list[int]:
    """Rows of the port's log where its gait computed (torques change only there; the clock's first tick
    and every 2 or 3 steps after). Found by replaying the port's ControlClock."""
    _project_on_path()
    from sparc_quad.gaits.authors_raibert import AuthorsRaibertParams
    from sparc_quad.sim.control_clock import ControlClock

    clock = ControlClock(AuthorsRaibertParams().control_period_s, 0.001)
    return [i for i in range(len(cols["t"])) if clock.tick()]


def _vx(t, x):
    import numpy as np

    t, x = np.asarray(t), np.asarray(x)
    v = np.gradient(x, t)
    return v


def compare(theirs: dict, cols: dict, metrics: dict, record_s: float) -> dict:
    """Their run against the port's: per-step states up to record_s (base height, hind pitch, forward
    velocity from x, spine q) and per-call leg and spine torques; max |diff| up to 0.5, 1, 2 s and when each
    first parts (beyond PART)."""
    import numpy as np

    s = theirs["series"]
    ts = np.asarray(s["t"])
    tp = np.asarray(cols["t"])
    # their row k is the state after step k (time ts[k]); the port's row with t == ts[k] is the same state
    idx = np.searchsorted(tp, ts - 1e-9)
    ok = (idx < len(tp)) & (ts <= record_s + 1e-9)
    idx, ts_ok = idx[ok], ts[ok]
    assert np.allclose(tp[idx], ts_ok, atol=1e-9), "time bases differ"
    pairs = {"z": (np.asarray(s["z"])[ok], cols["z"][idx]),
             "pitch": (np.asarray(s["pitch"])[ok], cols["q1_true"][idx]),
             "vx": (_vx(s["t"], s["x"])[ok], _vx(cols["t"], cols["x"])[idx]),
             "x": (np.asarray(s["x"])[ok], cols["x"][idx]),
             **{q: (np.asarray(s[q])[ok], cols[q][idx]) for q in ("q2", "q3", "q4")}}
    out: dict = {"states": {}, "torques": {}}
    for name, (a, b) in pairs.items():
        d = np.abs(a - b)
        part = PART[name]
        out["states"][name] = {**{f"max_diff_to_{t1:g}s": float(d[ts_ok <= t1 + 1e-9].max())
                                  for t1 in (0.5, 1.0, record_s)},
                               "part_s": _first(zip(ts_ok, d > part, strict=True)), "part_at": part}
    # per call: their probes against the port's rows where it computed
    rows = port_calls(cols)
    rows_t = tp[rows]
    # their clock is MuJoCo's accumulated float time (0.010000000000000002), the port's log i * dt
    tc = np.array([p["t"] for p in theirs["probes"]])
    tc = tc[tc < record_s - 1e-6]
    n = min(len(tc), int(np.sum(rows_t < record_s - 1e-6)))
    same_clock = bool(np.allclose(tc[:n], rows_t[:n], atol=1e-9)) and len(tc) == n
    out["calls"] = {"theirs": len(tc), "port": n, "same_times": same_clock}
    tau_t = np.array([p["tau"] for p in theirs["probes"]])[:n]
    r = np.asarray(rows[:n])
    legs = {}
    for leg, (ih, ik) in TAU_LEG_INDEX.items():
        legs[f"{leg}_hip"] = (tau_t[:, ih], cols[f"tau_{leg}_hfe"][r])
        legs[f"{leg}_knee"] = (tau_t[:, ik], cols[f"tau_{leg}_kfe"][r])
    for j, c in zip(TAU_SPINE_INDEX, ("tau2", "tau3", "tau4"), strict=True):
        legs[f"spine_{c}"] = (tau_t[:, j], cols[c][r])
    all_leg = np.max([np.abs(a - b) for k, (a, b) in legs.items() if not k.startswith("spine")], axis=0)
    for name, (a, b) in legs.items():
        d = np.abs(a - b)
        out["torques"][name] = {**{f"max_diff_to_{t1:g}s": float(d[tc[:n] <= t1 + 1e-9].max())
                                   for t1 in (0.5, 1.0, record_s)},
                                "part_s": _first(zip(tc[:n], d > PART["tau"], strict=True))}
    out["torques"]["legs_all"] = {**{f"max_diff_to_{t1:g}s": float(all_leg[tc[:n] <= t1 + 1e-9].max())
                                     for t1 in (0.5, 1.0, record_s)},
                                  "part_s": _first(zip(tc[:n], all_leg > PART["tau"], strict=True)),
                                  "part_at": PART["tau"], "their_max_abs": float(np.abs(tau_t[:, :]).max())}
    return out


PART = {"z": 0.005, "pitch": 0.02, "vx": 0.05, "x": 0.01, "q2": 0.02, "q3": 0.02, "q4": 0.02, "tau": 0.5}


def port_summary(cols: dict, metrics: dict, duration_s: float) -> dict:
    rows = port_calls(cols)
    out = summarize(cols["t"], cols["x"], cols["q1_true"], cols["pitch_front"], cols["roll"], len(rows),
                    duration_s)
    out["metrics_fell"] = bool(metrics.get("fell"))
    out["metrics_speed_m_s"] = metrics.get("speed_m_s")
    return out


FIXTURE_CASES = ((0.9, "spine"), (0.9, "locked"))  # the headline speed, both spines
FIXTURE_REPLAY_S = 0.7  # per-call inputs and leg torques kept (spine case) for replaying the leg law
FIXTURE_STEP_EVERY = 5  # per-step states kept every 5 ms


def _sig(v: float, digits: int = 10) -> float:
    return float(f"{float(v):.{digits}g}")


def fixture(results: list[dict], record_s: float) -> dict:
    """Their first seconds, compact, for FIXTURE_CASES: (the spine case) every control call up to
    FIXTURE_REPLAY_S with what their leg law was given (hind body z from xpos, quat wxyz from xquat, v_lin
    from cvel; q_legs, v_legs; v_front_x, v_hind_x: their R^T cvel readings) and the 8 leg torques it
    returned (HL hip, knee, HR, FL, FR; 10 significant digits); the states every FIXTURE_STEP_EVERY steps up
    to record_s (hind-body x, z, pitch, spine q, after each step); the 20 s summary."""
    out = []
    for r in results:
        if (r["speed_m_s"], r["spine"]) not in FIXTURE_CASES:
            continue
        pr = [p for p in r["probes"] if p["t"] < FIXTURE_REPLAY_S] if r["spine"] == "spine" else []
        legs = [i for leg in LEGS for i in TAU_LEG_INDEX[leg]]
        calls = {"t": [p["t"] for p in pr], "z": [_sig(p["q_full"][2]) for p in pr],
                 "quat": [[_sig(a) for a in p["q_full"][3:7]] for p in pr],
                 "v_lin": [[_sig(a) for a in p["v_full"][:3]] for p in pr],
                 **{k: [[_sig(a) for a in p[k]] for p in pr] for k in ("q_legs", "v_legs")},
                 **{k: [_sig(p[k]) for p in pr] for k in ("v_front_x", "v_hind_x")},
                 "tau_legs": [[_sig(p["tau"][i]) for i in legs] for p in pr]}
        s = r["series"]
        keep = [i for i, t in enumerate(s["t"]) if t <= record_s + 1e-9 and (i + 1) % FIXTURE_STEP_EVERY == 0]
        steps = {k: [_sig(s[k][i], 9) for i in keep] for k in ("t", "x", "z", "pitch", "q2", "q3", "q4")}
        out.append({"speed_m_s": r["speed_m_s"], "spine": r["spine"], "calls": calls, "steps": steps,
                    "summary": {k: r[k] for k in ("distance_m", "speed_window_m_s", "fell", "fall_s",
                                                  "gait_frequency_hz", "control_calls", "duration_s")}})
    first = results[0]
    return {"source": "tests/reference/run_authors_raibert.py: github.com/YueWang996/sparc 9aee563 "
                      "main_robot_raibert.py + dog_controller_raibert.py (MIT), headless, bard "
                      + first.get("bard_commit", BARD_COMMIT), "sha256": first["sha256"],
            "versions": first["versions"], "cases": out}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=(__doc__ or "").split("\n\n")[0])
    ap.add_argument("--src", type=Path, help="folder holding mujoco_simulation/ (see the sha256 table)")
    ap.add_argument("--bard", type=Path, help="git dir of the bard-pytorch-dynamics snapshot")
    ap.add_argument("--bard-commit", default=BARD_COMMIT)
    ap.add_argument("--venv", type=Path, help="venv with torch + mujoco + numpy + scipy + lxml + pyyaml")
    ap.add_argument("--case", action="append", default=[], help="SPEED:spine|locked, e.g. 0.9:spine")
    ap.add_argument("--duration", type=float, default=20.0, help="simulated seconds")
    ap.add_argument("--record", type=float, default=RECORD_S, help="seconds of per-call records")
    ap.add_argument("--port", action="store_true", help="also run the project's gait C and compare")
    ap.add_argument("--fixture", type=Path, help="write their first seconds here (the test's reference)")
    ap.add_argument("--series", action="store_true", help="keep per-step series and probes in the JSON")
    ap.add_argument("--fixture-from", type=Path, help="--fixture from a saved --series JSON")
    ap.add_argument("--out", type=Path, help="JSON written here")
    ap.add_argument("--driver", type=Path, help=argparse.SUPPRESS)
    a = ap.parse_args(argv)
    if a.driver:
        _driver(a.driver, a.record, a.out)
        return 0
    if a.fixture_from:
        if a.fixture is None:
            print("error: --fixture-from needs --fixture", file=sys.stderr)
            return 2
        saved = json.loads(a.fixture_from.read_text())["results"]
        a.fixture.write_text(json.dumps(fixture(saved, a.record), separators=(",", ":")) + "\n")
        return 0
    for name in ("src", "bard", "venv", "out"):
        if getattr(a, name) is None or (name != "out" and not getattr(a, name).exists()):
            print(f"error: --{name} missing or not found: {getattr(a, name)}", file=sys.stderr)
            return 2
    try:
        cases = []
        for c in a.case or ["0.5:spine", "0.9:spine", "1.3:spine", "0.5:locked", "0.9:locked", "1.3:locked"]:
            v, kind = c.split(":")
            if kind not in ("spine", "locked"):
                raise ValueError
            cases.append((float(v), kind == "locked"))
    except ValueError:
        print(f"error: --case must be SPEED:spine|locked, got {a.case}", file=sys.stderr)
        return 2
    results = []
    with tempfile.TemporaryDirectory(prefix="authors-raibert-") as tmp:
        work = Path(tmp)
        extract_bard(a.bard, a.bard_commit, work / "bard")
        for speed, locked in cases:
            r = run_case(a.src, work / "bard", a.venv, speed, locked, a.duration, a.record, work)
            r["bard_commit"] = a.bard_commit
            if a.port:
                cols, metrics = run_port(speed, locked, a.duration)
                r["port"] = port_summary(cols, metrics, a.duration)
                r["compare"] = compare(r, cols, metrics, a.record)
            results.append(r)
            shown = {k: v for k, v in r.items() if k not in ("series", "probes", "patches", "sha256")}
            print(json.dumps(shown), flush=True)
    if a.fixture:
        a.fixture.write_text(json.dumps(fixture(results, a.record), separators=(",", ":")) + "\n")
    if not a.series:
        for r in results:
            r.pop("series")
            r.pop("probes")
    a.out.write_text(json.dumps({"bard_commit": a.bard_commit, "results": results}, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
