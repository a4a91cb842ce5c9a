"""A child profile: what is known about the child the device is fitted to (SI units, years)."""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from typing import Literal

import numpy as np

from exoleg import checks as _check
from exoleg.errors import ParameterError
from exoleg.sizing import growth

#: The device was designed for these children (paper section 2).
DESIGN_AGES = (8.0, 12.0)
DESIGN_GMFCS = (1, 4)
#: A height or mass farther than this many SD from the growth chart is refused.
MAX_ABS_Z = 5.0


class DesignRangeWarning(UserWarning):
    """The child is outside the ages or GMFCS levels the device was designed for."""


@dataclass(frozen=True)
class Child:
    """A child to fit.

    Height and mass are checked against the growth chart of the child's group at its
    age (within +-5 SD, BMI within 5 SD of WHO 2007); :attr:`charts` names the chart used
    for each.

    Parameters
    ----------
    age : float
        Years (2-20, the growth charts' span; the device targets 8-12).
    sex : {"female", "male"}
        The growth charts' group.
    height : float
        m.
    mass : float
        Body mass, kg.
    gmfcs : int, optional
        GMFCS level 1-5; None (or 0) for a typically developing child.
    affected_side : {"left", "right"}, default "right"
        The leg the device is worn on.
    thigh, shank : float, optional
        Measured hip-knee and knee-ankle joint-centre distances, m.
    leg_length : float, optional
        Measured clinical leg length (ASIS to medial malleolus), m.
    foot_length : float, optional
        Heel to longest toe, m.
    ankle_height : float, optional
        Ankle joint centre above the sole, m. Each measured value overrides its estimate
        and must be plausible for the child's height
        (:func:`exoleg.sizing.anthropometry.plausible_range`) unless ``accept_unusual``.
    name : str, default "child"
        A label.
    accept_unusual : bool, default False
        Accept measured dimensions outside the plausible range (a child who really is out
        of the ordinary); reports say so.
    """

    age: float
    sex: Literal["female", "male"]
    height: float
    mass: float
    gmfcs: int | None = None
    affected_side: Literal["left", "right"] = "right"
    thigh: float | None = None
    shank: float | None = None
    leg_length: float | None = None
    foot_length: float | None = None
    ankle_height: float | None = None
    name: str = "child"
    accept_unusual: bool = False

    def __post_init__(self) -> None:
        w = f"Child {self.name!r}"
        age = _check.finite(w, "age", self.age)
        if not 2.0 <= age <= 20.0:
            raise ParameterError(w, "age", f"{age} years is outside 2-20 (the growth charts)")
        if self.sex not in ("female", "male"):
            raise ParameterError(w, "sex", f"unknown {self.sex!r} (allowed: female, male)")
        if self.gmfcs is not None:
            if (isinstance(self.gmfcs, bool) or not isinstance(self.gmfcs, (int, np.integer))
                    or self.gmfcs not in (0, 1, 2, 3, 4, 5)):
                raise ParameterError(w, "gmfcs", f"{self.gmfcs!r} ({type(self.gmfcs).__name__}) "
                                     "is not a GMFCS level (allowed: an integer 1-5, or 0 or "
                                     "None for typically developing)")
            object.__setattr__(self, "gmfcs", int(self.gmfcs) or None)
        _check.name(w, "name", self.name)
        if not isinstance(self.accept_unusual, bool):
            raise ParameterError(w, "accept_unusual", f"expected True or False, got "
                                 f"{self.accept_unusual!r}")
        if self.affected_side not in ("left", "right"):
            raise ParameterError(w, "affected_side",
                                 f"unknown {self.affected_side!r} (allowed: left, right)")
        object.__setattr__(self, "age", age)
        object.__setattr__(self, "height", _check.positive(w, "height", self.height, "m"))
        object.__setattr__(self, "mass", _check.positive(w, "mass", self.mass, "kg"))
        for f in ("thigh", "shank", "leg_length", "foot_length", "ankle_height"):
            v = getattr(self, f)
            if v is not None:
                object.__setattr__(self, f, _check.positive(w, f, v, "m"))
        charts = self.charts
        for measure, value, unit in (("height", self.height, "m"), ("weight", self.mass, "kg")):
            chart = charts[measure]
            z = growth.zscore(chart, self.sex, measure, age, value)
            if abs(z) > MAX_ABS_Z:
                lo = growth.value_at_z(chart, self.sex, measure, age, -MAX_ABS_Z)
                hi = growth.value_at_z(chart, self.sex, measure, age, MAX_ABS_Z)
                field = "height" if measure == "height" else "mass"
                raise ParameterError(w, field, f"{value:g} {unit} is {z:+.1f} SD from the {chart} "
                                     f"chart for a {age:g}-year-old {self.sex}; allowed within "
                                     f"+-{MAX_ABS_Z:g} SD: {lo:.3g}-{hi:.3g} {unit}")
        growth.check_bmi(w, self.sex, age, self.height, self.mass)
        if not DESIGN_AGES[0] <= age <= DESIGN_AGES[1]:
            warnings.warn(f"{w}: age {age:g} years is outside 8-12, the ages the device was "
                          "designed for", DesignRangeWarning, stacklevel=3)
        if self.gmfcs == 5:
            warnings.warn(f"{w}: GMFCS V is outside I-IV, the levels the device was designed for",
                          DesignRangeWarning, stacklevel=3)

    @property
    def chart(self) -> str:
        """The growth chart that describes this child (Brooks 2011 by GMFCS, or WHO 2007)."""
        return growth.chart_for(self.gmfcs)

    @property
    def charts(self) -> dict[str, str]:
        """The chart used for each measure at this age (``{"height": ..., "weight": ...}``):
        for a typically developing child CDC 2000 where WHO 2007 has no row."""
        return {m: growth.chart_for(self.gmfcs, m, self.age) for m in ("height", "weight")}


def group_name(g: int | None) -> str:
    return "TD" if g is None else f"GMFCS {'I II III IV V'.split()[g - 1]}"


def _mass(group: int | None, sex: str, age: float, pct: float) -> tuple[float, str]:
    chart = growth.chart_for(group, "weight", age)
    note = "" if chart == growth.chart_for(group) else (
        f"mass from {chart} ({growth.chart_for(group)} has no weight at {age:g} y)")
    return growth.value_at(chart, sex, "weight", age, pct), note


def population_child(group: int | None, sex: str, age: float, pct: float) -> tuple[Child, str]:
    """The child of a growth chart: height and mass at the same percentile ``pct`` of its
    group's chart (GMFCS 1-4: Brooks 2011; None: WHO 2007, CDC 2000 where WHO has no row)
    at ``age``, and a note when the mass came from another chart."""
    h = growth.value_at(growth.chart_for(group), sex, "height", age, pct)
    m, note = _mass(group, sex, age, pct)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DesignRangeWarning)
        c = Child(age=age, sex=sex, height=h, mass=m, gmfcs=group,  # type: ignore[arg-type]
                  name=f"{group_name(group)} {sex} {age:g} y P{pct:g}")
    return c, note
