"""Growth references by LMS: Brooks 2011 (cerebral palsy, by GMFCS level) and WHO 2007.

``value_at(chart, sex, "height", age, percentile)`` gives the height (m) or body
mass (kg) at a percentile; ``zscore`` the inverse. Ages in years, interpolated
linearly between the charts' rows (half years for Brooks, months for WHO).

Charts: ``"GMFCS1"`` .. ``"GMFCS4"``, ``"GMFCS5NT"`` (not tube-fed), ``"GMFCS5TF"``
(tube-fed) -- Brooks et al. 2011, 2-20 y; ``"WHO2007"`` -- typically developing children
(height 5-19 y, weight 5-10 y); ``"CDC2000"`` -- typically developing children, 2-20 y,
the fallback where WHO 2007 has no row (:func:`chart_for` with a measure and an age).
"""

from __future__ import annotations

import csv
import math
from functools import cache
from importlib import resources
from statistics import NormalDist

import numpy as np
from numpy.typing import NDArray

from exoleg.errors import ParameterError

F64 = NDArray[np.float64]
CHARTS = ("GMFCS1", "GMFCS2", "GMFCS3", "GMFCS4", "GMFCS5NT", "GMFCS5TF", "WHO2007", "CDC2000")
_PEDITOOLS = {"GMFCS1": "brooks_gmfcs_1", "GMFCS2": "brooks_gmfcs_2",
              "GMFCS3": "brooks_gmfcs_3", "GMFCS4": "brooks_gmfcs_4",
              "GMFCS5NT": "brooks_gmfcs_5_nt", "GMFCS5TF": "brooks_gmfcs_5_tf",
              "CDC2000": "cdc_2000_pedi"}
_SEX = {"male": "m", "female": "f"}


def chart_for(gmfcs: int | None, measure: str | None = None, age: float | None = None) -> str:
    """The chart of a GMFCS level (1-4; 5 -> not tube-fed), or WHO 2007 for None (TD).

    With a measure and an age: the chart that has that row -- for a typically developing
    child, CDC 2000 where WHO 2007 has none (weight after 10 y, anything before 5 y)."""
    if gmfcs is not None:
        return f"GMFCS{gmfcs}" if gmfcs < 5 else "GMFCS5NT"
    if measure is None or age is None:
        return "WHO2007"
    for sex in _SEX:
        ages = _tables().get(("WHO2007", sex, measure), (np.empty(0),))[0]
        if not len(ages) or not ages[0] - 1e-9 <= age <= ages[-1] + 1e-9:
            return "CDC2000"
    return "WHO2007"


def _text(name: str) -> str:
    return resources.files("exoleg").joinpath("data", "growth", name).read_text()


@cache
def _tables() -> dict[tuple[str, str, str], tuple[F64, F64]]:
    """(chart, sex, measure) -> (ages in years (n,), LMS (n, 3)); height in m, weight kg."""
    rows: dict[tuple[str, str, str], list[tuple[float, float, float, float]]] = {}
    inv = {v: k for k, v in _PEDITOOLS.items()}
    for r in csv.DictReader(_text("peditools_brooks2011_cp_and_cdc2000_LMS.csv").splitlines()):
        if r["chart"] not in inv or r["measure"] not in ("height", "weight"):
            continue
        sex = "male" if r["gender"] == "m" else "female"
        scale = 0.01 if r["measure"] == "height" else 1.0
        years = float(r["age"]) / (12.0 if r["age_units"] == "months" else 1.0)
        rows.setdefault((inv[r["chart"]], sex, r["measure"]), []).append(
            (years, float(r["L"]), float(r["M"]) * scale, float(r["S"])))
    who = list(csv.reader(_text("rcpch_WHO2007_5-19y_LMS.csv").splitlines()))[4:]
    cols = {("height", "male"): 2, ("height", "female"): 5, ("weight", "male"): 8,
            ("weight", "female"): 11, ("bmi", "male"): 14, ("bmi", "female"): 17}
    for (measure, sex), c in cols.items():
        scale = 0.01 if measure == "height" else 1.0
        for w in who:
            if len(w) > c + 2 and w[c + 1].strip():
                rows.setdefault(("WHO2007", sex, measure), []).append(
                    (float(w[1]), float(w[c]), float(w[c + 1]) * scale, float(w[c + 2])))
    out = {}
    for k, v in rows.items():
        a = np.array(sorted(v))
        out[k] = (a[:, 0], a[:, 1:])
    return out


def lms(chart: str, sex: str, measure: str, age: float) -> tuple[float, float, float]:
    """(L, M, S) at ``age`` years; M in m (height) or kg (weight)."""
    if chart not in CHARTS:
        raise ParameterError("growth chart", "chart", f"unknown {chart!r} (allowed: "
                             + ", ".join(CHARTS) + ")")
    if sex not in _SEX:
        raise ParameterError("growth chart", "sex", f"unknown {sex!r} (allowed: male, female)")
    key = (chart, sex, measure)
    if key not in _tables():
        raise ParameterError("growth chart", "measure",
                             f"{chart} has no {measure!r} for {sex} (allowed: height, weight)")
    ages, v = _tables()[key]
    if not (ages[0] - 1e-9 <= age <= ages[-1] + 1e-9):
        raise ParameterError("growth chart", "age",
                             f"{age} y is outside {chart}'s {measure} chart "
                             f"({ages[0]:g}-{ages[-1]:g} y)")
    L, M, S = (float(np.interp(age, ages, v[:, i])) for i in range(3))
    return L, M, S


def _lms_value(L: float, M: float, S: float, z: float) -> float:
    return M * math.exp(S * z) if abs(L) < 1e-12 else M * (1.0 + L * S * z) ** (1.0 / L)


def value_at(chart: str, sex: str, measure: str, age: float, percentile: float) -> float:
    """The measure (m or kg) at ``percentile`` (0-100, exclusive) for age and sex."""
    if not 0.0 < percentile < 100.0:
        raise ParameterError("growth chart", "percentile", f"must be in (0, 100), got {percentile}")
    return value_at_z(chart, sex, measure, age, NormalDist().inv_cdf(percentile / 100.0))


def value_at_z(chart: str, sex: str, measure: str, age: float, z: float) -> float:
    """The measure at z-score ``z``. Beyond +-3 SD the LMS curve is extended linearly by
    the distance between 2 and 3 SD (WHO 2007's restricted application of the LMS
    method), which keeps extreme skewed weights from growing without bound."""
    L, M, S = lms(chart, sex, measure, age)
    if abs(z) <= 3.0:
        return _lms_value(L, M, S, z)
    k = math.copysign(1.0, z)
    sd3, sd2 = _lms_value(L, M, S, 3.0 * k), _lms_value(L, M, S, 2.0 * k)
    return sd3 + (abs(z) - 3.0) * (sd3 - sd2)


def zscore(chart: str, sex: str, measure: str, age: float, value: float) -> float:
    """The z-score of ``value`` (m or kg) for age and sex; beyond +-3 SD by WHO 2007's
    restricted method (see :func:`value_at_z`)."""
    L, M, S = lms(chart, sex, measure, age)
    z = math.log(value / M) / S if abs(L) < 1e-12 else ((value / M) ** L - 1.0) / (L * S)
    if abs(z) <= 3.0:
        return z
    k = math.copysign(1.0, z)
    sd3, sd2 = _lms_value(L, M, S, 3.0 * k), _lms_value(L, M, S, 2.0 * k)
    return k * (3.0 + (value - sd3) / (sd3 - sd2))


#: A body mass index this many SD from the WHO 2007 BMI-for-age reference is implausible
#: (the WHO's own flag for biologically implausible values, abs(BAZ) > 5: WHO AnthroPlus
#: manual, 2009).
BMI_Z_IMPLAUSIBLE = 5.0


def check_bmi(where: str, sex: str, age: float, height: float, mass: float) -> None:
    """A ParameterError for a height and mass no child has together: a BMI beyond
    :data:`BMI_Z_IMPLAUSIBLE` SD of the WHO 2007 BMI-for-age reference (5-19 y; outside
    those ages not checked)."""
    bmi = mass / height**2
    try:
        z = zscore("WHO2007", sex, "bmi", age, bmi)
    except ParameterError:  # outside the reference's ages
        return
    if abs(z) > BMI_Z_IMPLAUSIBLE:
        raise ParameterError(where, "mass/height", f"{mass:g} kg at {height:g} m is a BMI of "
                             f"{bmi:.1f} kg/m^2, {z:+.1f} SD from the WHO 2007 reference at "
                             f"{age:g} y: not a child's (implausible beyond "
                             f"+-{BMI_Z_IMPLAUSIBLE:g} SD)")
