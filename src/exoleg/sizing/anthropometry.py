"""Estimating a child's dimensions from what is known, and how good each estimate is.

Estimators (each names its source):

* ``table1_rule``: the paper's Table 1 rule -- scale a typically developing child of
  similar height: X = H * X_td / H_td (110 x 63.9 / 112 = 62.8 cm).
* Joint-centre lengths from height, Drillis & Contini (1966) proportions as tabulated
  by Winter (Biomechanics and Motor Control of Human Movement, 4th ed., Fig. 4.1):
  hip-knee 0.245 H, knee-ankle 0.246 H, ankle height 0.039 H, foot length 0.152 H,
  greater-trochanter height 0.530 H. Adult proportions: no children's table exists in
  the shipped sources.
* Clinical leg length (ASIS to medial malleolus, what a gait laboratory measures):
  ``"linear"`` -- least squares on the 31 measured children shipped in
  ``data/anthropometry`` (Pinzone et al. 2014), computed from the data;
  ``"drillis"`` -- 0.530 H; ``"table1"`` -- the paper's rule.

:func:`estimator_errors` measures each leg-length estimator on the 31 children
(leave-one-out for the fitted one); the default is the one with the smallest error.
"""

from __future__ import annotations

import csv
from dataclasses import dataclass
from functools import cache
from importlib import resources
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from exoleg.errors import ParameterError
from exoleg.params import paper
from exoleg.sizing.child import Child

F64 = NDArray[np.float64]
LegLengthMethod = Literal["linear", "drillis", "table1"]

#: Drillis & Contini (1966) segment lengths as fractions of height (Winter 2009, Fig. 4.1).
DRILLIS = {"thigh": 0.245, "shank": 0.246, "ankle_height": 0.039, "foot_length": 0.152,
           "trochanter_height": 0.530}


def table1_rule(height: float, td_height: float, td_value: float) -> float:
    """Paper Table 1: scale a typically developing child's dimension by the height ratio.

    Parameters
    ----------
    height : float
        The child's height, m.
    td_height : float
        The reference child's height, m.
    td_value : float
        The reference child's dimension.

    Returns
    -------
    float
        ``td_value * height / td_height``.
    """
    return height * td_value / td_height


def table1_estimate(height: float, sex: str) -> tuple[float, float]:
    """Leg and foot length by the paper's Table 1 rule, from the paper's typically
    developing reference child of the same sex (Whitley 2008).

    Parameters
    ----------
    height : float
        m.
    sex : str
        "female" or "male".

    Returns
    -------
    leg_length, foot_length : float
        m.
    """
    t = paper.sizing()
    td = t["td_min"] if sex == "female" else t["td_max"]
    h_td = td["height_cm"] / 100
    return (table1_rule(height, h_td, td["leg_length_cm"] / 100),
            table1_rule(height, h_td, td["foot_length_cm"] / 100))


@cache
def measured_children() -> tuple[F64, F64, F64, F64]:
    """(age years, body mass kg, height m, clinical leg length m) of the 31 children."""
    text = resources.files("exoleg").joinpath(
        "data", "anthropometry", "pinzone2014_centre2_children.csv").read_text()
    rows = list(csv.DictReader(text.splitlines()))
    cols = ("age_years", "body_mass_kg", "height_m", "leg_length_m")
    return tuple(np.array([float(r[c]) for r in rows]) for c in cols)  # type: ignore[return-value]


def _linear_fit(h: F64, ll: F64) -> tuple[float, float]:
    a, b = np.polyfit(h, ll, 1)
    return float(a), float(b)


@cache
def leg_length_fit() -> tuple[float, float]:
    """(slope, intercept) of clinical leg length on height over the 31 children, m/m and m."""
    _, _, h, ll = measured_children()
    return _linear_fit(h, ll)


def leg_length(height: float, sex: str = "female",
               method: LegLengthMethod = "linear") -> float:
    """Clinical leg length (ASIS to medial malleolus), m, estimated from height."""
    if method == "linear":
        a, b = leg_length_fit()
        return a * height + b
    if method == "drillis":
        return DRILLIS["trochanter_height"] * height
    if method == "table1":
        return table1_estimate(height, sex)[0]
    raise ParameterError("leg_length", "method",
                         f"unknown {method!r} (allowed: linear, drillis, table1)")


@dataclass(frozen=True)
class EstimatorError:
    """Error of an estimator on the measured children (estimate - measured).

    Parameters
    ----------
    name : str
        The estimator.
    source : str
        Its reference.
    bias, rmse, max_abs : float
        m.
    n : int
        Children measured.
    """

    name: str
    source: str
    bias: float
    rmse: float
    max_abs: float
    n: int


def estimator_errors() -> list[EstimatorError]:
    """Each leg-length estimator on the 31 measured children (Pinzone et al. 2014).

    Returns
    -------
    list of EstimatorError
        Best (smallest RMSE) first.
    """
    _, _, h, ll = measured_children()
    loo = np.empty_like(h)
    for i in range(len(h)):
        keep = np.arange(len(h)) != i
        a, b = _linear_fit(h[keep], ll[keep])
        loo[i] = a * h[i] + b
    cands = {
        "linear": ("least squares on the 31 children (leave-one-out)", loo),
        "drillis": ("Drillis & Contini 1966: 0.530 H", DRILLIS["trochanter_height"] * h),
        "table1": ("paper Table 1 rule (Whitley 2008 TD proportions)",
                   np.array([table1_estimate(x, "female")[0] for x in h])),
    }
    out = []
    for name, (src, est) in cands.items():
        e = est - ll
        out.append(EstimatorError(name, src, float(e.mean()), float(np.sqrt((e * e).mean())),
                                  float(np.abs(e).max()), len(h)))
    return sorted(out, key=lambda r: r.rmse)


#: Measured joint-centre lengths and foot length are plausible within this factor of
#: their Drillis & Contini proportion of height (adult proportions; children's segment
#: proportions differ from them by about 10 %, so 25 % is wide of any real child);
#: ankle height, a small number measured with a large relative error, within 0.5-2x.
PLAUSIBLE_FACTOR = {"thigh": (0.75, 1.25), "shank": (0.75, 1.25),
                    "foot_length": (0.75, 1.25), "ankle_height": (0.5, 2.0)}
#: Measured clinical leg length is plausible within the leg-length-to-height ratios of
#: the 31 measured children (0.482-0.551, Pinzone 2014), widened by 10 % either way.
LEG_LENGTH_WIDENING = 0.10


def plausible_range(name: str, height: float) -> tuple[float, float]:
    """(lower, upper) m of a measured dimension for a child of ``height`` m
    (:data:`PLAUSIBLE_FACTOR`, :data:`LEG_LENGTH_WIDENING`)."""
    if name == "leg_length":
        _, _, h, ll = measured_children()
        r = ll / h
        return (float(r.min()) * (1 - LEG_LENGTH_WIDENING) * height,
                float(r.max()) * (1 + LEG_LENGTH_WIDENING) * height)
    lo, hi = PLAUSIBLE_FACTOR[name]
    return lo * DRILLIS[name] * height, hi * DRILLIS[name] * height


def check_measured(child: Child) -> list[str]:
    """The measured dimensions of ``child`` outside :func:`plausible_range`, described
    ("thigh 500.0 cm, plausible 23.6-39.4 cm for a height of 125.0 cm"). Raises
    ParameterError for the first unless ``child.accept_unusual``; returns them then."""
    out = []
    for name in ("thigh", "shank", "leg_length", "foot_length", "ankle_height"):
        v = getattr(child, name)
        if v is None:
            continue
        lo, hi = plausible_range(name, child.height)
        if not lo <= v <= hi:
            msg = (f"{v * 100:.1f} cm, plausible {lo * 100:.1f}-{hi * 100:.1f} cm for a "
                   f"height of {child.height * 100:.1f} cm")
            if not child.accept_unusual:
                raise ParameterError(f"Child {child.name!r}", name, msg + " (accept_unusual="
                                     "True, or --accept-unusual, for a child who really is)")
            out.append(f"{name} {msg}")
    return out


@dataclass(frozen=True)
class Dimensions:
    """A child's dimensions and where each came from.

    Parameters
    ----------
    thigh, shank : float
        Hip-knee and knee-ankle joint-centre distances, m.
    ankle_height : float
        Ankle joint centre above the sole, m.
    foot_length : float
        Heel to longest toe, m.
    leg_length : float
        Clinical leg length (ASIS to medial malleolus), m.
    sources : dict of str to str
        Per dimension, ``"measured"`` or the estimator.
    """

    thigh: float
    shank: float
    ankle_height: float
    foot_length: float
    leg_length: float
    sources: dict[str, str]


def estimate_dimensions(child: Child, leg_length_method: LegLengthMethod = "linear"
                        ) -> Dimensions:
    """The joint-centre lengths the device must align with, foot and clinical leg length.

    A measured clinical leg length scales the height-based thigh and shank estimates by
    measured / estimated leg length (the child's own proportions of leg to height).

    Parameters
    ----------
    child : Child
        The child (measured values used as given).
    leg_length_method : {"linear", "drillis", "table1"}, default "linear"
        How the clinical leg length is estimated when not measured.

    Returns
    -------
    Dimensions
    """
    unusual = check_measured(child)
    H = child.height
    src: dict[str, str] = {}

    def pick(name: str, estimate: float, how: str) -> float:
        v = getattr(child, name)
        src[name] = ("measured" + (" (unusual, accepted on request)"
                                   if any(u.startswith(name + " ") for u in unusual) else "")
                     if v is not None else how)
        return float(v) if v is not None else float(estimate)

    ll_est = leg_length(H, child.sex, leg_length_method)
    ll = pick("leg_length", ll_est, f"{leg_length_method} estimator from height")
    k = ll / ll_est if child.leg_length is not None else 1.0
    how = "Drillis & Contini 1966 proportion of height" + (
        " scaled to the measured leg length" if k != 1.0 else "")
    return Dimensions(
        thigh=pick("thigh", DRILLIS["thigh"] * H * k, how),
        shank=pick("shank", DRILLIS["shank"] * H * k, how),
        ankle_height=pick("ankle_height", DRILLIS["ankle_height"] * H,
                          "Drillis & Contini 1966 proportion of height"),
        foot_length=pick("foot_length", DRILLIS["foot_length"] * H,
                         "Drillis & Contini 1966 proportion of height"),
        leg_length=ll, sources=src)


#: A whole leg's share of body mass: thigh 0.100 + shank 0.0465 + foot 0.0145 (Dempster's
#: fractions as tabulated by Winter, Biomechanics and Motor Control of Human Movement).
LEG_FRACTION = 0.161


def body_weight_share(body_mass: float) -> float:
    """Mass the pelvis carries, kg: the child's body less both legs (:data:`LEG_FRACTION`
    each; this leg and the device are the leg model's, the other leg is the actor's)."""
    return body_mass * (1.0 - 2.0 * LEG_FRACTION)


def body_mass_of(share: float) -> float:
    """The child's body mass, kg, whose pelvis carries ``share`` kg
    (:func:`body_weight_share`'s inverse)."""
    return share / (1.0 - 2.0 * LEG_FRACTION)
