"""The predictcpgait child's passive moment curves (Falisse et al. 2020; shipped as
``data/child/falisse2020_cp_child_passive_moments.csv``) in exoleg's angles and signs,
and the six figures that tell its contracture apart (:func:`signatures`)."""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass
from functools import cache
from importlib import resources

import numpy as np
from numpy.typing import NDArray

from exoleg.child.passive import passive_moments
from exoleg.params.records import JOINTS

F64 = NDArray[np.float64]

#: the six signatures, in the clinic's angles (hip and knee flexion, ankle dorsiflexion,
#: degrees) and moments (N m)
SIGNATURES = ("knee rest angle, hip 0 (deg flexion)",
              "knee flexion moment at full extension, hip 90 (N m)",
              "knee zero-moment angle, hip 90 (deg flexion)",
              "ankle neutral angle, knee 0 (deg dorsiflexion)",
              "plantarflexor moment at 0 deg dorsiflexion, knee 0 (N m)",
              "dorsiflexion where the plantarflexors resist with 10 N m, knee 0 (deg)")


@dataclass(frozen=True)
class Curves:
    """Rows of the curves: ``params`` ('generic' or 'personalized'), ``joint`` index
    (0 hip, 1 knee, 2 ankle), ``q`` (n, 3) rad and ``moment`` (n,) N m at the swept
    joint, exoleg's signs (+ moves q +)."""

    params: NDArray[np.str_]
    joint: NDArray[np.int64]
    q: F64
    moment: F64

    def __getitem__(self, mask: NDArray[np.bool_]) -> Curves:
        return Curves(self.params[mask], self.joint[mask], self.q[mask], self.moment[mask])


def clinical_q(hip: float, knee: float, ankle: float) -> F64:
    """Hip and knee flexion and ankle dorsiflexion (degrees) -> exoleg's q (rad)."""
    return np.radians([hip, -knee, ankle])


@cache
def falisse_curves() -> Curves:
    text = resources.files("exoleg").joinpath(
        "data", "child", "falisse2020_cp_child_passive_moments.csv").read_text()
    rows = list(csv.DictReader(line for line in text.splitlines() if not line.startswith("#")))
    par, jnt, qs, ms = [], [], [], []
    for r in rows:
        ang = {k: float(v) for k, v in (kv.split("=") for kv in r["others"].split(";"))}
        ang[r["joint"]] = float(r["angle_deg"])
        j = JOINTS.index(r["joint"])
        m = float(r["total_Nm"])
        par.append(r["params"])
        jnt.append(j)
        qs.append(clinical_q(ang["hip"], ang["knee"], ang["ankle"]))
        ms.append(-m if j == 1 else m)  # the knee's flexion is -q2
    return Curves(np.array(par), np.array(jnt), np.array(qs), np.array(ms))


def bisect_root(f, lo: float, hi: float) -> float:  # type: ignore[no-untyped-def]
    """Where f changes sign in [lo, hi] (bisection); NaN if it does not."""
    a, b = f(lo), f(hi)
    if a == 0.0:
        return lo
    if a * b > 0:
        return math.nan
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        v = f(mid)
        if (v > 0) == (a > 0):
            lo, a = mid, v
        else:
            hi = mid
    return 0.5 * (lo + hi)


def signatures(P: NDArray[np.void]) -> tuple[float, ...]:
    """The six contracture signatures (:data:`SIGNATURES`) of the passive model ``P``."""
    def knee_flexion_moment(hip: float, knee: float) -> float:
        return -float(passive_moments(P, clinical_q(hip, knee, 0.0))[1])

    def dorsiflexion_moment(ankle: float) -> float:
        return float(passive_moments(P, clinical_q(0.0, 0.0, ankle))[2])

    return (bisect_root(lambda k: knee_flexion_moment(0.0, k), 0.0, 100.0),
            knee_flexion_moment(90.0, 0.0),
            bisect_root(lambda k: knee_flexion_moment(90.0, k), 30.0, 100.0),
            bisect_root(dorsiflexion_moment, -30.0, 30.0),
            -dorsiflexion_moment(0.0),
            bisect_root(lambda a: dorsiflexion_moment(a) + 10.0, -30.0, 40.0))


def curve_signatures(params: str) -> tuple[float, ...]:
    """The same six figures read off the shipped curves (linear interpolation)."""
    c = falisse_curves()
    c = c[c.params == params]

    def series(joint: int, fixed: dict[int, float]) -> tuple[F64, F64]:
        sel = c.joint == joint
        for i, v in fixed.items():
            sel &= np.isclose(c.q[:, i], v)
        ang = np.degrees(c.q[sel, joint]) * (-1 if joint == 1 else 1)
        mom = c.moment[sel] * (-1 if joint == 1 else 1)  # flexion/dorsiflexion +
        o = np.argsort(ang)
        return ang[o], mom[o]

    def zero(a: F64, m: F64, level: float = 0.0) -> float:
        s = np.nonzero(np.diff(np.sign(m - level)))[0][0]
        return float(np.interp(level, m[s:s + 2][::-1], a[s:s + 2][::-1])
                     if m[s] > m[s + 1] else np.interp(level, m[s:s + 2], a[s:s + 2]))

    k0 = series(1, {0: 0.0})
    k90 = series(1, {0: math.pi / 2})
    a0 = series(2, {1: 0.0})
    return (zero(*k0), float(np.interp(0.0, *k90)), zero(*k90), zero(*a0),
            -float(np.interp(0.0, *a0)), zero(*a0, -10.0))
