"""A short feedback gap resumes at full gain; only a real restart soft-starts again.

A fake clock drives `supervise` tick by tick (1 kHz) as the node does."""

from __future__ import annotations

from spine_module.messages import Fault, Mode
from spine_module.safety import Receipts, SafetyConfig, SafetyState, supervise

CFG = SafetyConfig()


def _run(state, t0: float, t1: float, feedback_at, requested=Mode.IMPEDANCE):
    """Ticks from t0 to t1 (1 ms); feedback_at(t) -> receipt time of the newest feedback."""
    out = []
    for k in range(round((t1 - t0) * 1000)):
        t = t0 + k * 1e-3
        rx = Receipts(torso=t, feedback=feedback_at(t), command=t, heartbeat=t)
        state, v = supervise(state, t, rx, requested, False, CFG)
        out.append((t, v))
    return state, out


def test_short_feedback_gap_resumes_at_full_gain():
    s, out = _run(SafetyState(), 0.0, 1.0, lambda t: t)
    assert out[-1][1].gain_scale == 1.0
    s, out = _run(s, 1.0, 1.02, lambda t: 1.0)  # 20 ms without feedback (4x the 5 ms deadline)
    stale = [v for _, v in out if v.faults & Fault.FEEDBACK_STALE]
    assert stale and all(v.mode == Mode.DISABLED and v.gain_scale == 0.0 and v.enable for v in stale)
    s, out = _run(s, 1.02, 1.03, lambda t: t)
    assert all(v.mode == Mode.IMPEDANCE and v.gain_scale == 1.0 for _, v in out)


def test_gap_during_the_ramp_continues_the_ramp():
    s, _ = _run(SafetyState(), 0.0, 0.2, lambda t: t)
    s, _ = _run(s, 0.2, 0.21, lambda t: 0.2)
    s, out = _run(s, 0.21, 0.22, lambda t: t)
    assert out[0][1].gain_scale == 0.21 / 0.5  # the ramp's clock kept running from t = 0


def test_long_gap_or_stop_soft_starts_again():
    s, _ = _run(SafetyState(), 0.0, 1.0, lambda t: t)
    s, _ = _run(s, 1.0, 1.0 + CFG.stale_resume_s + 0.05, lambda t: 1.0)
    t = 1.0 + CFG.stale_resume_s + 0.05
    s, out = _run(s, t, t + 0.1, lambda t: t)
    assert out[0][1].gain_scale == 0.0 and abs(out[-1][1].gain_scale - 0.099 / 0.5) < 1e-9
    s, _ = _run(s, t + 0.1, t + 1.0, lambda t: t)
    s, _ = _run(s, t + 1.0, t + 1.01, lambda t: t, requested=Mode.DISABLED)  # a real stop
    s, out = _run(s, t + 1.01, t + 1.02, lambda t: t)
    assert out[0][1].gain_scale == 0.0
