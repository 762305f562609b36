"""The residual plot shows the trial that holds the spans the report names, and says what it shades."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from sparc_quad.gap.report import plot_residual_time


def test_the_plot_shows_the_trial_with_the_largest_span(tmp_path):
    t = np.linspace(0.0, 2.0, 201)
    blocks = [SimpleNamespace(trial=SimpleNamespace(name=name, t=t), idx=np.arange(201)) for name in "abc"]
    res0 = [np.zeros((201, 2)) for _ in blocks]
    robot = SimpleNamespace(nv=2, joints=("q2", "q3"))
    report = {"localisation": {"spans": [{"trial": "c", "t0_s": 0.5, "t1_s": 0.7, "joint": "q3"},
                                         {"trial": "a", "t0_s": 1.0, "t1_s": 1.1, "joint": "q2"}]}}
    assert plot_residual_time(tmp_path / "r.png", report, robot, blocks, res0) == ("c", 1)  # not block 0
    assert (tmp_path / "r.png").is_file()
    assert plot_residual_time(tmp_path / "n.png", {"localisation": {"spans": []}}, robot, blocks, res0) == \
        ("a", 0)
