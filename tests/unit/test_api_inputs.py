"""What the Python API takes is checked where it enters: one ParameterError naming the
field and what is allowed -- never an AttributeError from deep inside, never a compiled
tick reading past the end of a short array. References: the plausible envelope of a leg's
link (exoleg.params.records: LINK_LENGTH_M, LINK_MASS_KG, the COM within the segment's
reach, a centroidal inertia at most m (2 L)^2) and the types each entry point documents.
"""

from __future__ import annotations

import math
import re

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import exoleg
from exoleg.control.safety import SafetyLayer
from exoleg.errors import ParameterError
from exoleg.params.records import Link
from exoleg.reference import SchwartzGait2008
from exoleg.sim.device_loop import simulate_device
from exoleg.sim.walk import simulate_walk
from exoleg.tick import Command

THIGH = {"mass": 2.3, "length": 0.30, "com": (0.12, 0.0), "izz": 0.02, "name": "thigh"}


@pytest.mark.parametrize(("change", "field", "says"), [
    ({"com": (5.0, 0.0)}, "com", "outside the link's reach"),
    ({"com": (0.12, -0.5)}, "com", "0.5 m from its 0.3 m segment"),
    ({"izz": 50.0}, "izz", "more than a 2.3 kg body within two lengths"),
    ({"mass": 1e6}, "mass", "1e+06 kg is outside 0.001-100 kg"),
    ({"length": 30.0}, "length", "30 m is outside 0.01-2 m"),
    ({"mass": float("nan")}, "mass", "finite"),
])
def test_an_implausible_link_is_refused_by_name(change: dict, field: str, says: str) -> None:
    with pytest.raises(ParameterError, match=re.escape(says)) as e:
        Link(**{**THIGH, **change})
    assert e.value.field == field


@settings(max_examples=200, deadline=None)
@given(a=st.floats(0.05, 1.0), m=st.floats(0.01, 50.0), s=st.floats(0.0, 1.0),
       r=st.floats(0.0, 0.999), th=st.floats(0.0, 6.283), k=st.floats(0.0, 2.0))
def test_links_within_the_envelope_are_accepted(a: float, m: float, s: float, r: float,
                                                th: float, k: float) -> None:
    # Property: any COM within one length of the segment and any radius of gyration up
    # to two lengths makes a valid link.
    izz = max(m * (k * a) ** 2, 1e-9)
    com = (s * a + r * a * np.cos(th), r * a * np.sin(th))
    link = Link(mass=m, length=a, com=com, izz=izz)
    assert link.length == a


def test_the_shipped_and_random_legs_are_within_the_envelope() -> None:
    # Reference: the envelope as documented (exoleg.params.records), recomputed here: each
    # link of the paper's legs and of the validation's random legs lies inside it, so the
    # new checks refuse none of them.
    from exoleg.params.records import LINK_LENGTH_M, LINK_MASS_KG
    from exoleg.validate.checks import random_leg

    rng = np.random.default_rng(0)
    for leg in (exoleg.paper_leg("simplified"), exoleg.paper_leg("detailed"),
                *(random_leg(rng) for _ in range(50))):
        for lk in leg.links:
            a, (x, y) = lk.length, lk.com
            assert LINK_LENGTH_M[0] <= a <= LINK_LENGTH_M[1]
            assert LINK_MASS_KG[0] <= lk.mass <= LINK_MASS_KG[1]
            assert np.hypot(x - np.clip(x, 0.0, a), y) <= a
            assert lk.izz <= lk.mass * (2 * a) ** 2


LEG = exoleg.paper_leg()
CTRL = exoleg.control.PDGravity(LEG)
REF = SchwartzGait2008()


@pytest.mark.parametrize("run", [exoleg.simulate, simulate_device])
@pytest.mark.parametrize(("args", "field"), [((LEG, "pd", REF), "controller"),
                                             ((LEG, CTRL, "gait"), "reference"),
                                             (("paper", CTRL, REF), "leg")])
def test_a_run_of_the_wrong_parts_is_refused_by_name(run, args: tuple, field: str) -> None:  # type: ignore[no-untyped-def]
    with pytest.raises(ParameterError) as e:
        run(*args, duration=0.1)
    assert e.value.field == field and "expected" in e.value.problem


def test_a_walk_of_the_wrong_leg_is_refused_by_name() -> None:
    with pytest.raises(ParameterError, match="leg: expected a LegModel"):
        simulate_walk("paper", 30.0, strides=1)  # type: ignore[arg-type]


@pytest.mark.parametrize(("q", "says"), [([0.1, 0.2], "expected 3 numbers, got shape (2,)"),
                                         ("upright", "expected 3 numbers"),
                                         ([[0.0] * 3], "expected 3 numbers, got shape (1, 3)")])
def test_the_safety_layer_refuses_readings_of_the_wrong_shape(q: object, says: str) -> None:
    layer = SafetyLayer()
    with pytest.raises(ParameterError, match=re.escape(f"q: {says}")):
        layer.step(q, np.zeros(3), np.zeros(3))  # type: ignore[arg-type]
    u, _ = layer.step([0.0, -0.1, 0.0], [np.nan, 0.0, 0.0], np.zeros(3))
    assert np.array_equal(u, np.zeros(3))  # a non-finite reading is a fault, not an error


def test_the_tracking_controller_checks_its_parts_and_readings() -> None:
    from exoleg.control.tracking import TrackingController

    with pytest.raises(ParameterError, match="law: expected a controller record"):
        TrackingController("pd-gravity", REF)  # type: ignore[arg-type]
    with pytest.raises(ParameterError, match="reference: expected a reference"):
        TrackingController(CTRL, [0.0, 0.0, 0.0])  # type: ignore[arg-type]
    c = TrackingController(CTRL, REF)
    with pytest.raises(ParameterError, match="fsr: expected 4 numbers"):
        c.update({"q": np.zeros(3), "dq": np.zeros(3), "fsr": np.zeros(3)}, Command.NONE,
                 0.0)


def test_the_stride_a_walk_expects_is_the_childs_own_or_refused() -> None:
    # the walking controller's expected stride (the child's last session's) is its own:
    # the simulated world walks the plan's
    from exoleg.system.build import build
    from exoleg.system.config import DeviceConfig

    config = DeviceConfig.load(None)
    system = build(config, exoleg.paper_leg(), 30.0, "walk", expected_stride=1.14)
    assert system.controller.d[0]["expected_stride"] == 1.14
    assert system.device is not None and system.device.stride_time == 1.1
    for bad in (0.1, math.nan, 9.0):
        with pytest.raises(ParameterError, match=r"build: expected_stride: .* is outside "
                                                 r"0\.4-4 s \(a stride a child can walk\)"):
            build(config, exoleg.paper_leg(), 30.0, "walk", expected_stride=bad)
