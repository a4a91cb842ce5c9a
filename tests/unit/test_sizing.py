"""Fitting the device to a child (issue 4), each number against its reference."""

import warnings

import numpy as np
import pytest

import exoleg
from exoleg.params import paper
from exoleg.sizing import (
    Child,
    DesignRangeWarning,
    estimate_dimensions,
    estimator_errors,
    fit_device,
    growth,
    personalized_leg,
    table1_estimate,
)
from exoleg.sizing.personal import device_bodies, jensen_mass_fractions


def test_table1_rule_reproduces_the_paper():
    # Paper Table 1 footnotes: 110 x 63.9 / 112 = 62.8 cm, 110 x 16.8 / 112 = 16.5 cm;
    # 143 x 84.5 / 141 = 85.7 cm, 143 x 21.4 / 141 = 21.7 cm.
    ll, fl = table1_estimate(1.10, "female")
    assert round(ll * 100, 1) == 62.8 and round(fl * 100, 1) == 16.5
    ll, fl = table1_estimate(1.43, "male")
    assert round(ll * 100, 1) == 85.7 and round(fl * 100, 1) == 21.7


def test_brooks_medians_are_the_papers_heights():
    # Paper Table 1: 110 cm (girl 8 y GMFCS IV) and 143 cm (boy 12 y GMFCS I), Brooks 2011.
    assert growth.value_at("GMFCS4", "female", "height", 8, 50) == pytest.approx(1.10, abs=0.005)
    assert growth.value_at("GMFCS1", "male", "height", 12, 50) == pytest.approx(1.43, abs=0.01)
    z = growth.zscore("WHO2007", "male", "height", 10, growth.value_at(
        "WHO2007", "male", "height", 10, 90))
    assert z == pytest.approx(1.2815515655446004, rel=1e-9)  # normal quantile of 0.9


def test_estimators_on_the_31_measured_children():
    # Reference: 31 children measured by Pinzone et al. 2014. Measured errors (RMSE):
    # linear fit 1.92 cm (leave-one-out), Drillis 0.530 H 2.72 cm, paper Table 1 rule 7.59 cm.
    errs = {e.name: e for e in estimator_errors()}
    assert errs["linear"].n == 31
    assert errs["linear"].rmse == pytest.approx(0.0192, abs=5e-4)
    assert errs["drillis"].rmse == pytest.approx(0.0272, abs=5e-4)
    assert errs["table1"].rmse == pytest.approx(0.0759, abs=5e-4)
    assert estimator_errors()[0].name == "linear"  # the default is the best on the evidence


def test_child_validation_names_field_and_range():
    with pytest.raises(exoleg.ParameterError, match=r"height.*SD.*allowed"):
        Child(age=9, sex="female", height=2.0, mass=24, gmfcs=3)
    with pytest.raises(exoleg.ParameterError, match="gmfcs"):
        Child(age=9, sex="female", height=1.25, mass=24, gmfcs=7)
    with pytest.raises(exoleg.ParameterError, match="mass"):
        Child(age=9, sex="female", height=1.25, mass=-3, gmfcs=3)
    with pytest.raises(exoleg.ParameterError, match="sex"):
        Child(age=9, sex="girl", height=1.25, mass=24)  # type: ignore[arg-type]
    with pytest.raises(exoleg.ParameterError, match="height"):
        Child(age=9, sex="female", height=float("nan"), mass=24)
    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        Child(age=14, sex="male", height=1.6, mass=50, gmfcs=5)
    assert sum(issubclass(x.category, DesignRangeWarning) for x in w) == 2


def test_measured_values_override_estimates():
    c = Child(age=10, sex="male", height=1.35, mass=30, thigh=0.33, foot_length=0.2,
              leg_length=0.70)
    d = estimate_dimensions(c)
    assert d.thigh == 0.33 and d.foot_length == 0.2 and d.sources["thigh"] == "measured"
    assert "scaled to the measured leg length" in d.sources["shank"]


def test_fit_verdicts_and_misses():
    small = fit_device(Child(age=8, sex="female", height=1.10, mass=19.1, gmfcs=4))
    assert not small.fits and small.paper_rule["fits"]
    lower = [m for m in small.misses if m.what.startswith("lower")][0]
    assert lower.by == pytest.approx(0.285 * 1.10 - 0.33, abs=1e-12)  # (0.246 + 0.039) H - 33 cm
    big = fit_device(Child(age=12, sex="male", height=1.43, mass=37.4, gmfcs=1))
    assert big.fits and not big.misses
    assert big.link_lengths[1] == pytest.approx(0.246 * 1.43)


def test_device_part_gives_back_table4_at_the_papers_setting():
    # Issue 4: at the paper's setting the device part is Table 4's SLE (masses, lengths).
    t4 = paper.table4()
    bodies = device_bodies(t4["sle"]["length"][0], t4["sle"]["length"][1])
    assert np.allclose([b.mass for b in bodies], t4["sle"]["mass"], rtol=1e-14)
    sle = [lk.parts[1] for lk in paper.detailed_links()]
    assert np.allclose([b.izz for b in bodies], [b.izz for b in sle], rtol=1e-12)


def test_personalized_leg_composes_child_and_device():
    c = Child(age=9.5, sex="female", height=1.25, mass=24.0, gmfcs=3)
    leg = personalized_leg(c)
    frac = jensen_mass_fractions(9.5)
    for i, name in enumerate(("thigh", "shank", "foot")):
        human, sle = leg.links[i].parts
        assert human.mass == pytest.approx(24.0 * frac[name], rel=1e-14)
        assert leg.links[i].mass == pytest.approx(human.mass + sle.mass, rel=1e-14)
    # Jensen fractions between 6 y (1989) and 12 y (1986): thigh 8.48 % -> 10.98 %
    assert frac["thigh"] == pytest.approx(0.0848303 + (0.1097804 - 0.0848303) * 3.5 / 6, rel=1e-5)
    assert leg.lengths[2] == pytest.approx(0.235)


def test_jensen_fractions_use_the_rescaled_column():
    # Reference: Jensen 1986 12 y rescaled percentages in the shipped table (thigh 10.978 %).
    assert jensen_mass_fractions(12.0)["thigh"] == pytest.approx(0.1097804391, rel=1e-9)
