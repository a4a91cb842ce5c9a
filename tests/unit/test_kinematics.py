"""Kinematics (paper section 3) against the D-H product and finite differences."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import exoleg
from exoleg.kinematics import dh_transform
from exoleg.params import paper

LEG = exoleg.paper_leg()
ROM = paper.range_of_motion()
angle = st.floats(-np.pi, np.pi)


@given(angle, angle, angle)
@settings(deadline=None)  # its first example compiles; on a loaded machine that took 200 ms
def test_fk_equals_dh_product(t1, t2, t3):
    # Reference: paper eqs 1-4, the product of the D-H transforms of Table 3.
    a = LEG.lengths
    off = LEG.offsets
    T = dh_transform(t1 + off[0], a[0]) @ dh_transform(t2 + off[1], a[1]) @ dh_transform(
        t3 + off[2], a[2])
    fk = LEG.fk([t1, t2, t3])
    assert np.allclose(fk["toe"], T[:2, 3], atol=1e-15)
    assert np.allclose([np.cos(fk["phi"]), np.sin(fk["phi"])], T[:2, 0], atol=1e-15)
    # eqs 5-6 as printed
    px = a[1] * np.sin(t1 + t2) + a[0] * np.sin(t1) + a[2] * np.cos(t1 + t2 + t3)
    py = -a[1] * np.cos(t1 + t2) - a[0] * np.cos(t1) + a[2] * np.sin(t1 + t2 + t3)
    assert np.allclose(fk["toe"], [px, py], atol=1e-15)


@given(st.floats(0, 1), st.floats(0, 1), st.floats(0, 1))
@settings(max_examples=300)
def test_ik_inverts_fk_over_range_of_motion(u1, u2, u3):
    q = ROM.lower + np.array([u1, u2, u3]) * (ROM.upper - ROM.lower)
    q[1] = min(q[1], -1e-3)  # the flexed branch (q2 = 0 is where the branches meet)
    fk = LEG.fk(q)
    back = LEG.ik(fk["toe"][0], fk["toe"][1], fk["phi"])
    # the knee from an arccos: its error grows as 1 / |sin q2| towards the straight knee
    # where the branches meet -- measured over 3000 poses at each of q2 = -0.001, -0.01,
    # -0.1, -1 rad, error x |sin q2| at most 1.2-1.4e-15 (1.23e-12 at -0.001, which a
    # fixed 1e-12 refused once in CI's hypothesis draws)
    assert np.max(np.abs(back - q)) < 1e-14 + 4e-15 / abs(np.sin(q[1]))
    other = LEG.ik(fk["toe"][0], fk["toe"][1], fk["phi"], branch="extended")
    assert other[1] == pytest.approx(-q[1], abs=1e-12)
    assert np.allclose(LEG.fk(other)["toe"], fk["toe"], atol=1e-14)


def test_ik_unreachable_is_a_clear_error():
    with pytest.raises(exoleg.UnreachableError, match="out of reach"):
        LEG.ik(1.0, -0.2, 0.0)
    with pytest.raises(exoleg.ParameterError, match="branch"):
        LEG.ik(0.2, -0.5, 0.0, branch="up")  # type: ignore[arg-type]


def test_standing_pose():
    # q = 0: thigh and shank straight down, foot forward (docs/conventions.md).
    fk = LEG.fk([0.0, 0.0, 0.0])
    a = LEG.lengths
    assert np.allclose(fk["ankle"], [0.0, -(a[0] + a[1])], atol=1e-16)
    assert np.allclose(fk["toe"], [a[2], -(a[0] + a[1])], atol=1e-16)


def test_jacobians_match_finite_differences():
    rng = np.random.default_rng(5)
    for _ in range(20):
        q = rng.uniform(-2, 2, 3)
        J = LEG.jacobians(q)
        for name, Jn in J.items():
            num = np.zeros((2, 3))
            for j in range(3):
                e = np.zeros(3)
                e[j] = 1e-6
                num[:, j] = (LEG.fk(q + e)[name] - LEG.fk(q - e)[name]) / 2e-6
            assert np.allclose(Jn, num, atol=1e-9), name
