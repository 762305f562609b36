"""The numba-compiled control step equals the pinocchio reference path, input by input."""

from __future__ import annotations

import dataclasses
import os
import subprocess
import sys

import numpy as np
import pytest

from spine_module import params as P
from spine_module.control import ImpedanceController, StribeckFriction, TaskPDController
from spine_module.model import SpineModel
from tests.paths import ROOT

pytest.importorskip("numba")

MODEL = SpineModel()
TOL = 1e-9
FIELDS = ("tau", "tau_raw", "x", "dx")


def _pair(kind: str, model: SpineModel = MODEL):
    def make(backend: str):
        if kind == "impedance":
            return ImpedanceController(model, StribeckFriction.nominal(), backend=backend)
        if kind == "impedance_no_friction":
            return ImpedanceController(model, None, backend=backend)
        return TaskPDController(model, backend=backend)
    return make("numba"), make("pinocchio")


def _random_states(rng: np.random.Generator, n: int):
    for _ in range(n):
        q = P.Q_EQUILIBRIUM + rng.uniform(-0.7, 0.7, 4)
        q[0] = rng.uniform(-np.pi, np.pi)
        dq = rng.normal(0.0, 3.0, 4)
        yield q, dq, float(rng.normal(0.0, 50.0))


def _compare(fast, ref, rng: np.random.Generator, n: int, moving: bool = False) -> int:
    """`moving`: a random base acceleration too (hind-body frame, up to ~30 m/s^2)."""
    saturated = 0
    for q, dq, ddq1 in _random_states(rng, n):
        k, d = rng.uniform(0.0, 4000.0, 3), rng.uniform(0.0, 100.0, 3)
        x_d = P.X_EQUILIBRIUM + rng.uniform(-0.05, 0.05, 3)
        dx_d, ddx_d = rng.normal(0.0, 0.5, 3), rng.normal(0.0, 20.0, 3)
        acc = rng.normal(0.0, 10.0, 3) if moving else None
        for c in (fast, ref):
            c.set_gains(k, d)
            c.set_target(x_d, dx_d, ddx_d)
        a, b = fast.step(q, dq, ddq1, acc), ref.step(q, dq, ddq1, acc)
        assert a.ok and b.ok
        for f in FIELDS:
            np.testing.assert_allclose(getattr(a, f), getattr(b, f), rtol=0, atol=TOL, err_msg=f)
        np.testing.assert_array_equal(a.saturated, b.saturated)
        saturated += int(a.saturated.any())
    return saturated


@pytest.mark.parametrize("kind", ["impedance", "impedance_no_friction", "pd"])
def test_compiled_step_matches_pinocchio_on_random_states(kind: str) -> None:
    fast, ref = _pair(kind)
    assert fast.backend == "numba" and ref.backend == "pinocchio"
    saturated = _compare(fast, ref, np.random.default_rng(11), 1000)
    assert 0 < saturated < 1000  # both the clamp and the free case were exercised


@pytest.mark.parametrize("kind", ["impedance", "impedance_no_friction", "pd"])
def test_compiled_step_matches_pinocchio_with_a_moving_base(kind: str) -> None:
    fast, ref = _pair(kind)
    saturated = _compare(fast, ref, np.random.default_rng(12), 1000, moving=True)
    assert 0 < saturated < 1000


def _translating_base_model(model: SpineModel):
    """The spine model behind a 3-D translation joint: an independent model of a base whose origin
    accelerates (its RNEA takes the acceleration as the joint's, in the world frame)."""
    import pinocchio as pin

    tr = pin.buildModelFromXML(model.urdf, pin.JointModelTranslation())
    tr.gravity.linear = model.model.gravity.linear.copy()
    tr.armature[3:] = model.model.armature
    return tr


def test_base_acceleration_is_a_translating_base() -> None:
    """RNEA with the base acceleration (SpineModel.rnea, i.e. gravity g - a) and both controller paths
    equal pinocchio's RNEA of the model on a translation joint driven at that acceleration, whatever its
    velocity (Galilean invariance): tau from the controllers minus their J^T F and friction terms."""
    import pinocchio as pin

    tr = _translating_base_model(MODEL)
    dtr = tr.createData()
    rng = np.random.default_rng(3)
    fast, ref = _pair("impedance_no_friction")
    for c in (fast, ref):
        c.set_gains((0.0, 0.0, 0.0), (0.0, 0.0, 0.0))  # tau = RNEA(q, dq, ddq*) alone
    worst = 0.0
    for q, dq, ddq1 in _random_states(rng, 300):
        acc = rng.normal(0.0, 10.0, 3)  # hind-body frame
        data = MODEL.create_data()
        ddq = np.r_[ddq1, rng.normal(0.0, 5.0, 3)]
        tau = MODEL.rnea(data, q, dq, ddq, acc).copy()
        pin.forwardKinematics(MODEL.model, data.dyn, q)
        acc_world = data.dyn.oMi[1].rotation @ acc
        want = pin.rnea(tr, dtr, np.r_[rng.normal(0.0, 1.0, 3), q], np.r_[rng.normal(0.0, 3.0, 3), dq],
                        np.r_[acc_world, ddq])[3:]
        worst = max(worst, float(np.abs(tau - want).max()))
        # the controllers: ddq* is their own; compare with the translating base at their ddq*
        a, b = fast.step(q, dq, ddq1, acc), ref.step(q, dq, ddq1, acc)
        assert a.ok and b.ok
        ddq_star = np.r_[ddq1, ref._ddq_act]
        want = pin.rnea(tr, dtr, np.r_[np.zeros(3), q], np.r_[np.zeros(3), dq],
                        np.r_[acc_world, ddq_star])[4:]
        np.testing.assert_allclose(a.tau_raw, want, rtol=0, atol=TOL)
        np.testing.assert_allclose(b.tau_raw, want, rtol=0, atol=TOL)
    assert worst < TOL
    # and a base acceleration is not nothing: 1 m/s^2 forward changes the torque
    q = P.Q_EQUILIBRIUM
    moved = fast.step(q, np.zeros(4), 0.0, np.array([1.0, 0.0, 0.0])).tau_raw.copy()
    assert np.abs(moved - fast.step(q, np.zeros(4), 0.0).tau_raw).max() > 1e-3


@pytest.mark.parametrize("kind", ["impedance", "impedance_no_friction", "pd"])
def test_zero_base_acceleration_is_the_fixed_origin_law_bit_for_bit(kind: str) -> None:
    rng = np.random.default_rng(4)
    fast, ref = _pair(kind)
    for q, dq, ddq1 in _random_states(rng, 100):
        for c in (fast, ref):
            without = c.step(q, dq, ddq1).tau_raw.tolist()
            assert c.step(q, dq, ddq1, np.zeros(3)).tau_raw.tolist() == without


def test_compiled_step_is_generated_from_the_model() -> None:
    """A different spine (masses, lengths, armature, gravity) needs no change to the kernel."""
    links = tuple(dataclasses.replace(link, mass_kg=link.mass_kg * 1.7, length_m=link.length_m * 1.2)
                  for link in P.LINKS)
    spine = dataclasses.replace(P.DEFAULT_SPINE, links=links, armature_kg_m2=4e-3)
    model = SpineModel(spine, gravity_m_s2=3.7)
    for kind in ("impedance", "pd"):
        fast, ref = _pair(kind, model)
        _compare(fast, ref, np.random.default_rng(5), 200)
        _compare(fast, ref, np.random.default_rng(6), 200, moving=True)


def test_friction_switch_reaches_the_kernel() -> None:
    fast, ref = _pair("impedance")
    q, dq = P.Q_EQUILIBRIUM, np.array([0.0, 0.3, -0.2, 0.1])
    with_f = fast.step(q, dq).tau_raw.copy()
    fast.friction_enabled = ref.friction_enabled = False
    without = fast.step(q, dq).tau_raw.copy()
    np.testing.assert_allclose(without, ref.step(q, dq).tau_raw, atol=TOL)
    np.testing.assert_allclose(with_f - without, StribeckFriction.nominal().torque(dq[1:]), atol=TOL)
    assert fast.friction_enabled is False


@pytest.mark.parametrize("kind", ["impedance", "pd"])
@pytest.mark.parametrize("bad", ["q", "dq", "ddq1", "base_accel"])
def test_non_finite_input_gives_zero_torque_and_the_same_error(kind: str, bad: str) -> None:
    fast, ref = _pair(kind)
    for value in (np.nan, np.inf):
        q, dq, ddq1, acc = P.Q_EQUILIBRIUM.copy(), np.zeros(4), 0.0, np.zeros(3)
        if bad == "q":
            q[2] = value
        elif bad == "dq":
            dq[3] = value
        elif bad == "ddq1":
            ddq1 = value
        else:
            acc[1] = value
        a_ok = fast.step(P.Q_EQUILIBRIUM, np.zeros(4)).ok
        a = fast.step(q, dq, ddq1, acc)
        b = ref.step(q, dq, ddq1, acc)
        assert a_ok
        assert (a.ok, a.error) == (b.ok, b.error)
        if not a.ok:
            assert not a.tau.any() and not a.saturated.any()
            assert bad in a.error
        else:  # PD does not use ddq1 or the base acceleration
            assert kind == "pd" and bad in ("ddq1", "base_accel")


@pytest.mark.parametrize("q, dq", [
    (np.zeros(3), np.zeros(3)),  # wrong length: the kernel refuses, never reads past the end
    (np.zeros(5), np.zeros(4)),
])
def test_wrong_shape_is_named(q: np.ndarray, dq: np.ndarray) -> None:
    fast, ref = _pair("impedance")
    a = fast.step(q, dq)
    assert not a.ok and "4 joints" in a.error
    assert a.error == ref.step(q, dq).error


def test_other_layouts_and_dtypes_fall_back_to_the_reference() -> None:
    fast, ref = _pair("impedance")
    q = P.Q_EQUILIBRIUM + 0.05
    wide = np.zeros(8)
    wide[::2] = q  # non-contiguous view
    for qq, dd in ((wide[::2], np.zeros(4)), (list(q), [0.0] * 4), (q.astype(np.float32), np.zeros(4))):
        a = fast.step(qq, dd).tau.copy()
        b = ref.step(qq, dd).tau
        np.testing.assert_allclose(a, b, atol=1e-9)


def test_backend_names() -> None:
    with pytest.raises(ValueError, match="backend"):
        ImpedanceController(MODEL, backend="cuda")
    assert TaskPDController(MODEL, backend="pinocchio").backend == "pinocchio"


def test_second_process_loads_the_cached_kernel() -> None:
    """Compile cost is paid once per machine (numba cache), not by every process of a sweep."""
    code = ("import spine_module.control.compiled as c; s = c.spine_step.stats; "
            "print(sum(s.cache_misses.values()), sum(s.cache_hits.values()))")
    root = ROOT
    env = {**os.environ, "PYTHONPATH": str(root)}
    runs = [subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, cwd=root,
                           timeout=300, check=True).stdout.split() for _ in range(2)]
    assert runs[1] == ["0", "1"], runs
