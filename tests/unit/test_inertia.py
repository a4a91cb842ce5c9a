"""SMS composition (paper Appendix C) and its inverse."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import exoleg
from exoleg.inertia import RigidBody, compose, remainder
from exoleg.params import paper

mass = st.floats(0.01, 10.0)
coord = st.floats(-0.5, 0.5)
izz = st.floats(1e-5, 0.5)
body = st.builds(lambda m, x, y, i: RigidBody(mass=m, com=(x, y), izz=i), mass, coord, coord, izz)


@given(st.lists(body, min_size=1, max_size=5))
def test_compose_preserves_mass_first_moment_and_origin_inertia(bodies):
    # Reference: the definitions -- mass, first moment and inertia about any fixed
    # point are additive over welded bodies.
    c = compose(bodies)
    assert c.mass == pytest.approx(sum(b.mass for b in bodies), rel=1e-14)
    first = sum(b.mass * np.array(b.com) for b in bodies)
    assert np.allclose(c.mass * np.array(c.com), first, rtol=1e-12, atol=1e-14)
    assert c.izz_origin == pytest.approx(sum(b.izz_origin for b in bodies), rel=1e-12)


@given(body, body)
@settings(max_examples=200)
def test_remainder_inverts_compose(a, b):
    total = compose([a, b])
    r = remainder(total, a)
    assert r.mass == pytest.approx(b.mass, rel=1e-9)
    assert np.allclose(r.com, b.com, rtol=1e-7, atol=1e-9)
    assert r.izz == pytest.approx(b.izz, rel=1e-6, abs=1e-9)


def test_compose_is_associative():
    a = RigidBody(1.0, (0.1, 0.0), 0.01)
    b = RigidBody(2.0, (0.2, 0.05), 0.02)
    c = RigidBody(0.5, (-0.1, 0.02), 0.003)
    x, y = compose([compose([a, b]), c]), compose([a, compose([b, c])])
    assert x.izz == pytest.approx(y.izz, rel=1e-14)
    assert np.allclose(x.com, y.com, rtol=1e-14)


def test_table4_human_plus_sle_is_table5_detailed_mass():
    # Reference: paper Table 4 (human, SLE) sums to Table 5 detailed masses (to the
    # 15 printed decimals).
    t4 = paper.table4()
    detailed = paper.table5_links("detailed")
    for i, lk in enumerate(detailed):
        assert t4["human"]["mass"][i] + t4["sle"]["mass"][i] == pytest.approx(lk.mass, abs=2e-15)


def test_detailed_parts_compose_to_table5_and_sle_masses_are_table4():
    t4 = paper.table4()
    leg = exoleg.paper_leg("detailed")
    for i, (lk, ref) in enumerate(zip(leg.links, paper.table5_links("detailed"), strict=True)):
        human, sle = lk.parts
        assert sle.mass == pytest.approx(t4["sle"]["mass"][i], rel=1e-14)
        c = compose(lk.parts)
        assert c.mass == pytest.approx(ref.mass, rel=1e-15)
        assert c.izz == pytest.approx(ref.izz, rel=1e-13)
        assert np.allclose(c.com, ref.com, rtol=1e-13, atol=1e-16)


def test_simplified_is_half_detailed():
    # Reference: paper section 6 -- simplified mass and inertia are half the detailed.
    for s, d in zip(paper.table5_links("simplified"), paper.table5_links("detailed"), strict=True):
        assert s.mass == pytest.approx(d.mass / 2, rel=1e-15)
        assert s.izz == pytest.approx(d.izz / 2, rel=1e-12)


def test_remainder_refuses_an_unphysical_split():
    total = RigidBody(1.0, (0.0, 0.0), 1e-4)
    spread = RigidBody(0.5, (0.2, 0.0), 1e-4)
    with pytest.raises(exoleg.ParameterError, match="izz"):
        remainder(total, spread)
    with pytest.raises(exoleg.ParameterError, match="mass"):
        remainder(total, RigidBody(2.0, (0.0, 0.0), 1e-4))
