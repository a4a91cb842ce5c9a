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


# ------------------------------------------------------- one-state calls (exoleg.dynamics.single)
_CALLS = {  # method -> number of state arguments
    "M": 1, "C": 2, "Cdq": 2, "G": 1, "Mdot": 2, "forward_dynamics": 3, "inverse_dynamics": 3,
}


def test_single_state_fast_path_is_built_and_used():
    # The C extension must be present where the package was built with a compiler (CI):
    # without it every call silently takes the slow general path.
    from exoleg.dynamics import single

    assert single.call is not None
    q = RNG.uniform(-3, 3, 3)
    out = single.call(single.ADDRESS.gravity, single.VECTOR, LEG.g, LEG.p, q)
    assert out is not None and np.array_equal(out, LEG.G(q[None])[0])


def test_single_state_equals_batched_for_every_input_form():
    # Reference: the broadcasting gufunc path (batch of one), which shares no code with the
    # one-state path but the generated kernel: results must agree bit for bit, whatever
    # form the one state comes in (float64 array, list, int array, strided view, float32).
    for _ in range(20):
        states = [RNG.uniform(-3, 3, 3) for _ in range(3)]
        for name, n in _CALLS.items():
            f = getattr(LEG, name)
            want = f(*(s[None] for s in states[:n]))[0]
            forms = [
                [s for s in states[:n]],
                [s.tolist() for s in states[:n]],
                [np.repeat(s, 2)[::2] for s in states[:n]],  # non-contiguous views
            ]
            for args in forms:
                assert np.array_equal(f(*args), want), name
    ints = np.array([1, -2, 0])
    assert np.array_equal(LEG.G(ints), LEG.G(ints.astype(float)))


def test_single_state_fk_equals_numpy_kinematics():
    # Reference: exoleg.kinematics.forward_kinematics (numpy) on the same leg.
    from exoleg import kinematics

    for q in RNG.uniform(-3, 3, (20, 3)):
        fast = LEG.fk(q)
        ref = kinematics.forward_kinematics(q, LEG.lengths, LEG.coms, LEG.offsets)
        assert fast.keys() == ref.keys()
        for k in ref:
            assert np.allclose(fast[k], ref[k], rtol=0, atol=1e-15), k


def test_single_state_non_finite_is_named():
    import pytest

    for bad in (np.array([np.nan, 0.0, 0.0]), np.array([0.0, np.inf, 0.0])):
        with pytest.raises(exoleg.ParameterError, match="q: must be finite"):
            LEG.G(bad)
        with pytest.raises(exoleg.ParameterError, match="q: must be finite"):
            LEG.fk(bad)
    with pytest.raises(exoleg.ParameterError, match="tau: must be finite"):
        LEG.forward_dynamics(np.zeros(3), np.zeros(3), np.array([0.0, 0.0, np.nan]))
