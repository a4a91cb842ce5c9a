"""Growth references by LMS: Brooks 2011 (cerebral palsy, by GMFCS level) and WHO 2007.

``value_at(chart, sex, "height", age, percentile)`` gives the height (m) or body
mass (kg) at a percentile; ``zscore`` the inverse. Ages in years, interpolated
linearly between the charts' rows (half years for Brooks, months for WHO).

Charts: ``"GMFCS1"`` .. ``"GMFCS4"``, ``"GMFCS5NT"`` (not tube-fed), ``"GMFCS5TF"``
(tube-fed) -- Brooks et al. 2011; ``"WHO2007"`` -- typically developing children
(height 5-19 y, weight 5-10 y).
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
CHARTS = ("GMFCS1", "GMFCS2", "GMFCS3", "GMFCS4", "GMFCS5NT", "GMFCS5TF", "WHO2007")
_BROOKS = {"GMFCS1": "brooks_gmfcs_1", "GMFCS2": "brooks_gmfcs_2", "GMFCS3": "brooks_gmfcs_3",
           "GMFCS4": "brooks_gmfcs_4", "GMFCS5NT": "brooks_gmfcs_5_nt",
           "GMFCS5TF": "brooks_gmfcs_5_tf"}
_SEX = {"male": "m", "female": "f"}


def chart_for(gmfcs: int | None) -> str:
    """The chart of a GMFCS level (1-4; 5 -> not tube-fed), or WHO 2007 for None (TD)."""
    if gmfcs is None:
        return "WHO2007"
    return f"GMFCS{gmfcs}" if gmfcs < 5 else "GMFCS5NT"


def _text(name: str) -> str:
    return resources.files("exoleg").joinpath("data", "growth", name).read_text()


@cache
def _tables() -> dict[tuple[str, str, str], tuple[F64, F64]]:
    """(chart, sex, measure) -> (ages in years (n,), LMS (n, 3)); height in m, weight kg."""
    rows: dict[tuple[str, str, str], list[tuple[float, float, float, float]]] = {}
    inv = {v: k for k, v in _BROOKS.items()}
    for r in csv.DictReader(_text("peditools_brooks2011_cp_and_cdc2000_LMS.csv").splitlines()):
        if r["chart"] not in inv or r["measure"] not in ("height", "weight"):
            continue
        sex = "male" if r["gender"] == "m" else "female"
        scale = 0.01 if r["measure"] == "height" else 1.0
        rows.setdefault((inv[r["chart"]], sex, r["measure"]), []).append(
            (float(r["age"]), float(r["L"]), float(r["M"]) * scale, float(r["S"])))
    who = list(csv.reader(_text("rcpch_WHO2007_5-19y_LMS.csv").splitlines()))[4:]
    cols = {("height", "male"): 2, ("height", "female"): 5, ("weight", "male"): 8,
            ("weight", "female"): 11}
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


def value_at(chart: str, sex: str, measure: str, age: float, percentile: float) -> float:
    """The measure (m or kg) at ``percentile`` (0-100, exclusive) for age and sex."""
    if not 0.0 < percentile < 100.0:
        raise ParameterError("growth chart", "percentile", f"must be in (0, 100), got {percentile}")
    z = NormalDist().inv_cdf(percentile / 100.0)
    L, M, S = lms(chart, sex, measure, age)
    return M * math.exp(S * z) if abs(L) < 1e-12 else M * (1.0 + L * S * z) ** (1.0 / L)


def zscore(chart: str, sex: str, measure: str, age: float, value: float) -> float:
    """The z-score of ``value`` (m or kg) for age and sex."""
    L, M, S = lms(chart, sex, measure, age)
    return math.log(value / M) / S if abs(L) < 1e-12 else ((value / M) ** L - 1.0) / (L * S)
