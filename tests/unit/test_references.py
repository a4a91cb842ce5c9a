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
