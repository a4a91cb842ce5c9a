"""References: step, minimum-jerk, normative gait."""

import numpy as np
import pytest

import exoleg
from exoleg.reference import MinJerk, SchwartzGait2008, Steps, schwartz2008


def test_steps_hold_postures():
    s = Steps([0, 3], [[0.1, -0.2, 0.0], [0.3, -0.5, 0.1]])
    q, dq, _ = s.sample([0.0, 2.999, 3.0, 10.0])
    assert np.allclose(q[:, 0], [0.1, 0.1, 0.3, 0.3]) and not dq.any()
    with pytest.raises(exoleg.ParameterError, match="increasing"):
        Steps([0, 0], [[0, 0, 0], [0, 0, 0]])
    with pytest.raises(exoleg.ParameterError, match="postures"):
        Steps([0, 1], [[0, 0, 0]])


def test_minjerk_boundary_conditions_and_derivatives():
    # Reference: the quintic 10 t^3 - 15 t^4 + 6 t^5 (Flash & Hogan 1985): rest to rest,
    # peak speed 1.875 x average at mid-time; derivatives by finite differences.
    m = MinJerk([0, 2], [[0, 0, 0], [1, -1, 0.5]])
    q, dq, ddq = m.sample([0.0, 1.0, 2.0])
    assert np.allclose(q[0], 0) and np.allclose(q[2], [1, -1, 0.5])
    assert np.allclose(dq[[0, 2]], 0) and np.allclose(ddq[[0, 2]], 0)
    assert dq[1, 0] == pytest.approx(1.875 * 0.5)
    t = np.linspace(0.1, 1.9, 50)
    h = 1e-6
    num = (m.sample(t + h)[0] - m.sample(t - h)[0]) / (2 * h)
    assert np.allclose(num, m.sample(t)[1], atol=1e-7)


def test_gait_fits_schwartz_and_maps_signs():
    # Reference: Schwartz 2008 printed samples; knee flexion + there is q2 < 0 here.
    g = SchwartzGait2008(stride_time=1.0)
    assert g.fit_residual() < np.radians(0.3)  # measured 0.23 deg (10 harmonics)
    pct, knee, _ = schwartz2008("knee_flexion")
    q, _, _ = g.sample(pct / 100.0)
    assert np.corrcoef(q[:, 1], -np.radians(knee))[0, 1] > 0.999
    # velocity is the time derivative of q at the chosen stride time
    t = np.linspace(0, 2, 400)
    num = np.gradient(g.sample(t)[0], t, axis=0)
    assert np.allclose(num[5:-5], g.sample(t)[1][5:-5], atol=2e-2)
    # periodic
    assert np.allclose(g.sample([0.3])[0], g.sample([1.3])[0], atol=1e-12)


def test_upright_gait_is_the_printed_hip_less_the_pelvis_s_tilt():
    # Reference: Schwartz 2008's printed hip flexion and pelvic tilt. The hip from an
    # upright pelvis is the printed hip less the tilt's mean over the cycle (11.6 deg at
    # the free speed); knee and ankle unchanged.
    from exoleg.reference.gait import gait_angles, pelvic_tilt

    pct, tilt, _ = schwartz2008("pelvis_tilt")
    assert np.degrees(pelvic_tilt()) == pytest.approx(np.mean(tilt[:-1]), rel=1e-12)
    _, printed = gait_angles()
    _, upright = gait_angles(upright=True)
    assert np.allclose(upright[:, 0], printed[:, 0] - pelvic_tilt(), atol=1e-15)
    assert np.array_equal(upright[:, 1:], printed[:, 1:])
    # the foot's angle to the ground (the joints' sum) through the foot-flat part of
    # stance, 14-30 % of the cycle: within 2 deg of flat on the upright pelvis
    # (measured -0.2 to -1.7), 9.9-11.4 deg toe-up with the printed hip
    flat = (pct >= 14) & (pct <= 30)
    assert np.all(np.abs(np.degrees(upright[flat].sum(axis=1))) < 2.0)
    assert np.all(np.degrees(printed[flat].sum(axis=1)) > 9.0)


def test_gait_bad_options():
    with pytest.raises(exoleg.ParameterError, match="speed"):
        SchwartzGait2008(speed="Jogging")
    with pytest.raises(exoleg.ParameterError, match="stride_time"):
        SchwartzGait2008(stride_time=0)


def test_a_walk_starts_at_rest_and_joins_the_gait():
    # reference.gait.start_pace / start_blend: the pace a minimum-jerk rise (Flash & Hogan
    # 1985) whose integral is the gait's time, and the reference q0 + b (gait - q0) with
    # the gait played at pace b -- checked as exact identities against finite differences
    # of their own values (central, step 1e-5 s: truncation ~1e-8 of the figures here)
    from exoleg.reference.gait import START_RAMP, start_blend, start_pace

    T = START_RAMP
    assert start_pace(0.0) == (0.0, 0.0, 0.0, 0.0)
    assert start_pace(T) == (0.5 * T, 1.0, 0.0, 0.0)  # the gait lags half the ramp
    assert start_pace(T + 0.3) == (T + 0.3 - 0.5 * T, 1.0, 0.0, 0.0)
    end = start_pace(T * (1.0 - 1e-12))
    assert end == pytest.approx((0.5 * T, 1.0, 0.0, 0.0), abs=1e-9)  # joins it smoothly
    h = 1e-5
    for tau in np.linspace(0.01, T - 0.01, 9):
        lo, mid, hi = start_pace(tau - h), start_pace(tau), start_pace(tau + h)
        for k in range(3):  # elapsed' = b, b' = b1, b1' = b2
            assert (hi[k] - lo[k]) / (2 * h) == pytest.approx(mid[k + 1], rel=1e-6, abs=1e-7)
    # the gait a sinusoid of its own time: the blended reference's derivatives are its
    # rate and acceleration as start_blend gives them
    q0, A, w = 0.1, 0.3, 2 * np.pi / 1.1

    def reference(tau):
        e, b, b1, b2 = start_pace(tau)
        g, dg, ddg = A * np.sin(w * e), A * w * np.cos(w * e), -A * w * w * np.sin(w * e)
        return start_blend(q0, g, dg, ddg, (b, b1, b2))

    assert reference(0.0) == (q0, 0.0, 0.0)
    e = T + 0.2 - 0.5 * T
    assert reference(T + 0.2) == pytest.approx((A * np.sin(w * e), A * w * np.cos(w * e),
                                                -A * w * w * np.sin(w * e)), abs=1e-15)
    for tau in np.linspace(0.01, T - 0.01, 9):
        lo, mid, hi = reference(tau - h), reference(tau), reference(tau + h)
        assert (hi[0] - lo[0]) / (2 * h) == pytest.approx(mid[1], rel=1e-6, abs=1e-8)
        assert (hi[1] - lo[1]) / (2 * h) == pytest.approx(mid[2], rel=1e-6, abs=1e-6)
