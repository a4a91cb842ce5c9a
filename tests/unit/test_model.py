"""LegModel behaviour: broadcasting, consistency of forward and inverse dynamics, energy."""

import numpy as np

import exoleg

LEG = exoleg.paper_leg()
RNG = np.random.default_rng(7)


def test_forward_then_inverse_dynamics_returns_tau():
    Q, DQ, TAU = (RNG.uniform(-3, 3, (200, 3)) for _ in range(3))
    ddq = LEG.forward_dynamics(Q, DQ, TAU)
    assert np.allclose(LEG.inverse_dynamics(Q, DQ, ddq), TAU, rtol=1e-12, atol=1e-11)


def test_batch_equals_single():
    Q = RNG.uniform(-3, 3, (5, 3))
    assert np.allclose(LEG.M(Q)[3], LEG.M(Q[3]), rtol=1e-15, atol=1e-17)  # gufunc vs direct
    assert LEG.G(Q).shape == (5, 3) and LEG.M(Q).shape == (5, 3, 3)


def test_kinetic_energy_is_quadratic_form_of_M():
    Q, DQ = RNG.uniform(-3, 3, (50, 3)), RNG.uniform(-3, 3, (50, 3))
    T = 0.5 * np.einsum("ni,nij,nj->n", DQ, LEG.M(Q), DQ)
    assert np.allclose(LEG.kinetic_energy(Q, DQ), T, rtol=1e-13)


def test_gravity_is_gradient_of_potential():
    for q in RNG.uniform(-3, 3, (20, 3)):
        num = [(LEG.potential_energy(q + e) - LEG.potential_energy(q - e)) / 2e-6
               for e in np.eye(3) * 1e-6]
        assert np.allclose(LEG.G(q), num, atol=1e-8)


def test_mdot_matches_finite_difference():
    q, dq = RNG.uniform(-3, 3, 3), RNG.uniform(-3, 3, 3)
    h = 1e-6
    num = (LEG.M(q + h * dq) - LEG.M(q - h * dq)) / (2 * h)
    assert np.allclose(LEG.Mdot(q, dq), num, atol=1e-8)


def test_mass_matrix_is_symmetric_positive_definite():
    for q in RNG.uniform(-np.pi, np.pi, (100, 3)):
        M = LEG.M(q)
        assert np.array_equal(M, M.T)
        assert np.all(np.linalg.eigvalsh(M) > 0)


def test_detailed_is_twice_simplified():
    # Paper Table 5: detailed masses and inertias are twice the simplified.
    d, s = exoleg.paper_leg("detailed"), exoleg.paper_leg("simplified")
    Q = RNG.uniform(-3, 3, (50, 3))
    assert np.allclose(d.M(Q), 2 * s.M(Q), rtol=1e-12)
    assert np.allclose(d.G(Q), 2 * s.G(Q), rtol=1e-12, atol=1e-12)
