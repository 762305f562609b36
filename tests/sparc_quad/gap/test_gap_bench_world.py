"""The pybullet bench world loads a gap plant-effects file (the `--plant FILE` integration point)."""

from __future__ import annotations

import numpy as np
import pytest

from sparc_quad.effects import Effect, PlantEffects
from sparc_quad.sim.bench_world import BenchWorld
from sparc_quad.sim.plant import PlantConfig
from spine_module import params as P

J = list(P.ACTUATED_JOINTS)


def _run(effects, tau, steps=200):
    cfg = PlantConfig().ideal()
    with BenchWorld(plant=cfg, effects=effects) as w:
        q0 = w.state().q.copy()
        for _ in range(steps):
            w.step(tau)
        return q0, w.state(), w.feedback()


def test_effects_change_the_bench_plant():
    tau = np.array([-0.9, -0.3, 0.0])
    _, base, _ = _run(None, tau)
    pe = PlantEffects(J, [Effect("encoder_offset", "q2", {"offset_rad": 0.05}),
                          Effect("torque_gain", "q3", {"gain": 0.5}),
                          Effect("coulomb_friction", "q4", {"tau_c_nm": 0.2}),
                          Effect("rotor_inertia", "q3", {"inertia_kg_m2": 1e-3})])
    _, st, fb = _run(pe, tau)
    assert np.all(np.isfinite(st.q))
    assert fb.q[0] - st.q[1] == pytest.approx(0.05, abs=1e-3)  # the encoder reads the offset
    assert abs(st.q[2] - base.q[2]) > 1e-3  # half the torque on q3 moves it differently


def test_delay_holds_the_first_commands():
    pe = PlantEffects(J, [Effect("time_delay", "q3", {"delay_s": 0.005})])
    cfg = PlantConfig().ideal()
    with BenchWorld(plant=cfg, effects=pe) as w:
        w.step(np.array([0.0, 1.0, 0.0]))
        assert w.last_applied[1] == 0.0
        for _ in range(5):
            w.step(np.array([0.0, 1.0, 0.0]))
        assert w.last_applied[1] == 1.0


def test_payload_rejected():
    pe = PlantEffects(J, [Effect("payload_mass", "q3", {"mass_kg": 0.1, "xyz_m": [0, 0, 0]})])
    with pytest.raises(ValueError, match="payload"):
        BenchWorld(effects=pe)
