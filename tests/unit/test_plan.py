"""An excitation plan's samples (exoleg.identify.plan.Plan.at) against the Fourier series
evaluated directly: each harmonic's sine and cosine of its own angle, and their
derivatives term by term (the analytic reference; the plan computes the harmonics by the
angle-addition recurrence from the first)."""

import numpy as np

from exoleg.identify.plan import Plan


def test_the_recurrence_gives_the_series_itself() -> None:
    # the longest plan the device plays (2 minutes: 24 s x 5) at 1 kHz, 8 harmonics (the
    # designed plans have 5). Measured: q 1.3e-14 rad off; dq and ddq 1.9e-14 and 2.0e-14
    # of their largest -- the docstring's bound, 1e-12, with room for other seeds
    rng = np.random.default_rng(3)
    n = 8
    plan = Plan(24.0, 5, rng.uniform(-0.3, 0.3, 3), rng.uniform(-0.2, 0.2, (3, n)),
                rng.uniform(-0.2, 0.2, (3, n)))
    t, q, dq, ddq = plan.sample()
    assert t[-1] == plan.duration
    kw = np.arange(1, n + 1) * 2 * np.pi / plan.period
    s, c = np.sin(np.outer(t, kw)), np.cos(np.outer(t, kw))
    want = (plan.centre + s @ plan.a.T + c @ plan.b.T,
            (c * kw) @ plan.a.T - (s * kw) @ plan.b.T,
            -(s * kw**2) @ plan.a.T - (c * kw**2) @ plan.b.T)
    assert np.abs(q - want[0]).max() <= 1e-12
    for got, ref in zip((dq, ddq), want[1:], strict=True):
        assert np.abs(got - ref).max() <= 1e-12 * np.abs(ref).max()
