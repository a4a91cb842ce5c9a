"""Passive joint moments of the child: Riener & Edrich's double exponentials with their
two-joint coupling (``data/child/passive.toml``), made a conservative field, scaled to
the child by height^5 (Lebiedowska & Fisk 1999), with contracture as shortened muscles
(``data/child/contracture.toml``).

Each term k is a muscle group's passive force ``F_k = exp(a_k + b_k . phi)`` with phi =
(phi_A, phi_K, phi_H) in Riener's degrees (ankle plantarflexion, knee and hip flexion
positive), acting on every joint its exponent depends on through moment arms
proportional to b_k: ``M_i = sign_k (b_k,i / b_k,own) F_k`` -- on its own joint Riener's
form, and the field the gradient of ``sum_k sign_k F_k / b_k,own``: no loop of postures
gains or loses energy. (Riener & Edrich print each term on its own joint alone, which is
not conservative; the terms' a and b are refitted to their equations,
``tools/fit_passive_potential.py``.) A joint's moment is the sum of the terms' and a
constant. For a child of height H the moments are scaled by s = (H / H_ref)^5 (``ln s``
added to every a, the constants multiplied by s). A contracted muscle group's force
``exp(a + da + f_own b_own phi_own + f_cpl b_cpl . phi_cpl)``: ``da`` is the shortening
(its passive force rises at a shorter stretch), ``f_own`` and ``f_cpl`` the steeper rise
of shorter fibres over its own joint and over the joints it crosses besides -- a group
stands for several muscles, and the ratio of its moment arms shifts as they shorten
unequally (f_cpl / f_own within :data:`ARM_SHIFT`); each scaled by the contracture
level.

Beyond the range the moments were measured over (:data:`VALID_DEG`) each term's force
goes on along its tangent in its stretch ``b . phi`` (never below zero) instead of
growing exponentially -- a function of the stretch alone, so the field stays
conservative there too.
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, field
from functools import cache
from importlib import resources
from typing import Any

import numpy as np
from numba import njit
from numpy.typing import NDArray

from exoleg import checks as _check
from exoleg.errors import ParameterError
from exoleg.layout import F8, new
from exoleg.params.records import JOINTS

F64 = NDArray[np.float64]

#: muscle groups a term may stand for ("limit": the joint's own end-range structures)
GROUPS = ("hip_flexors", "hip_extensors", "knee_flexors", "knee_extensors", "limit",
          "plantarflexors", "dorsiflexors")
#: each coordinate's range in Riener's degrees (phi_A plantarflexion +, phi_K, phi_H
#: flexion +) over which the curves were measured and checked (the predictcpgait
#: child's sweeps); the terms continue on their tangents beyond
VALID_DEG = ((-30.0, 30.0), (0.0, 100.0), (-20.0, 90.0))
#: How far a contracted group's moment arms may shift: f_cpl / f_own within these (a
#: muscle's own arms are anatomy; a group's ratio shifts as its muscles shorten
#: unequally -- a free fit made the knee flexors' arm at the hip 1.6x their arm at the
#: knee, and the hip 56 N m extending at hip 90 / knee 90 deg)
ARM_SHIFT = (0.5, 2.0)
#: The contracture levels a preset may be taken at (0 none, 1 as measured).
CONTRACTURE_LEVELS = (0.0, 1.5)
N_TERMS = 7

#: The passive model as the compiled code reads it: per term its joint (0 hip, 1 knee,
#: 2 ankle), sign, exponent coefficients (a, b_A, b_K, b_H) with the child's scale and
#: contracture applied, the moment it gives each joint (hip, knee, ankle; Riener's
#: signs) per unit of its force (``arm``: sign b_i / b_own), and the range of its
#: stretch b . phi over the checked range (``span``, degrees: the force's tangent
#: beyond); per joint its constant (N m, scaled) and viscous damping (N m s/rad); ``on``
#: 0 for a leg without a child model.
PASSIVE = np.dtype([("on", F8), ("joint", F8, N_TERMS), ("sign", F8, N_TERMS),
                    ("coef", F8, (N_TERMS, 4)), ("arm", F8, (N_TERMS, 3)),
                    ("span", F8, (N_TERMS, 2)), ("constant", F8, 3), ("damping", F8, 3)])


@cache
def child_data(name: str) -> dict[str, Any]:
    """One of the child model's shipped data files (``data/child/NAME``), parsed once per
    process (read only: every child's records are built from it)."""
    text = resources.files("exoleg").joinpath("data", "child", name).read_text()
    return tomllib.loads(text)


@dataclass(frozen=True)
class Term:
    joint: int
    group: str
    sign: float
    a: float
    b: tuple[float, float, float]


@dataclass(frozen=True)
class RienerModel:
    """The adults' model as printed (``data/child/passive.toml``)."""

    terms: tuple[Term, ...]
    constant: tuple[float, float, float]
    reference_height: float
    source: str = field(default="", compare=False)

    @classmethod
    def shipped(cls) -> RienerModel:
        """The model as ``data/child/passive.toml`` holds it."""
        d = child_data("passive.toml")
        terms = tuple(Term(JOINTS.index(t["joint"]), t["group"], float(t["sign"]),
                           float(t["a"]), tuple(float(v) for v in t["b"]))  # type: ignore[arg-type]
                      for t in d["term"])
        return cls(terms, tuple(float(c) for c in d["constant"]),  # type: ignore[arg-type]
                   float(d["reference_height_m"]), str(d["source"]))


@dataclass(frozen=True)
class Contracture:
    """Shortened muscles, at ``level`` 1 (0 is none).

    Parameters
    ----------
    name : str
        The preset's name.
    groups : dict of str to (float, float, float)
        Per muscle group (:data:`GROUPS` but "limit"): the shortening ``da`` (added to
        the term's exponent) and the steepening of its own (``f_own``) and coupled
        (``f_cpl``) coordinates, f_cpl / f_own within :data:`ARM_SHIFT`.
    level : float, default 1.0
        How much of it: 0 none, 1 as measured.
    constant : (float, float, float), default (0, 0, 0)
        The change of each joint's constant moment (Riener's units, N m at the reference
        height).
    source : str, default ""
        Where the numbers come from.
    """

    name: str
    groups: dict[str, tuple[float, float, float]]
    level: float = 1.0
    constant: tuple[float, float, float] = (0.0, 0.0, 0.0)
    source: str = field(default="", compare=False)

    def __post_init__(self) -> None:
        lv = _check.finite("contracture", "level", self.level)
        lo, hi = CONTRACTURE_LEVELS
        if not lo <= lv <= hi:
            raise ParameterError("contracture", "level", f"{lv:g} is outside {lo:g}-{hi:g} "
                                 "(0 none, 1 the preset as measured)")
        for g, v in self.groups.items():
            if g not in GROUPS or g == "limit":
                raise ParameterError("contracture", g, "unknown muscle group (allowed: "
                                     + ", ".join(x for x in GROUPS if x != "limit") + ")")
            lo_, hi_ = ARM_SHIFT
            if not (len(v) == 3 and all(math.isfinite(x) for x in v)
                    and -5 <= v[0] <= 5 and 0.1 <= v[1] <= 5
                    and lo_ * (1 - 1e-3) <= v[2] / v[1] <= hi_ * (1 + 1e-3)):  # (files round)
                raise ParameterError("contracture", g, f"{v!r}: expected [da (-5..5), "
                                     f"f_own (0.1..5), f_cpl ({lo_:g}-{hi_:g} x f_own: "
                                     "the group's moment arms shift so far)]")

    @classmethod
    def none(cls) -> Contracture:
        """No contracture.

        Returns
        -------
        Contracture
        """
        return cls("none", {}, 0.0)

    @classmethod
    def preset(cls, name: str, level: float = 1.0) -> Contracture:
        """A shipped preset (``data/child/contracture.toml``).

        Parameters
        ----------
        name : str
            ``none`` or a measured child's (``predictcpgait``).
        level : float, default 1.0
            How much of it: 0 none, 1 as measured.

        Returns
        -------
        Contracture
        """
        if name == "none":
            cls("none", {}, level)  # a level given with it is checked all the same
            return cls.none()
        d = child_data("contracture.toml")
        if name not in d:
            raise ParameterError("contracture", "preset", f"unknown {name!r} (allowed: none, "
                                 + ", ".join(sorted(d)) + ")")
        p = d[name]
        return cls(name, {g: tuple(float(x) for x in v) for g, v in p["groups"].items()},  # type: ignore[misc]
                   level, tuple(float(x) for x in p.get("constant", (0, 0, 0))),  # type: ignore[arg-type]
                   str(p.get("source", "")))


#: which coordinate (0 A, 1 K, 2 H) is a term's own joint's
_OWN = {0: 2, 1: 1, 2: 0}


def height_scale(height: float, model: RienerModel | None = None) -> float:
    """Lebiedowska & Fisk's height^5 law: a child of ``height`` m's passive moments,
    damping and tone as a fraction of the model's adults'."""
    m = RienerModel.shipped() if model is None else model
    return (height / m.reference_height) ** 5


def passive_record(height: float, contracture: Contracture | None = None,
                   damping: tuple[float, float, float] = (0.0, 0.0, 0.0),
                   model: RienerModel | None = None) -> NDArray[np.void]:
    """The compiled passive-moment model (:data:`PASSIVE`) for a child of ``height`` m.

    Parameters
    ----------
    height : float
        m (Riener & Edrich's moments scale with height^5).
    contracture : Contracture, optional
        Shortened muscles; default none.
    damping : (float, float, float), default (0, 0, 0)
        Joint damping, N m s/rad.
    model : RienerModel, optional
        The passive model's coefficients; default the shipped ones.

    Returns
    -------
    ndarray
        A one-element :data:`PASSIVE` record.
    """
    m = RienerModel.shipped() if model is None else model
    c = Contracture.none() if contracture is None else contracture
    h = _check.finite("passive", "height", height)
    if not 0.5 <= h <= 2.2:
        raise ParameterError("passive", "height", f"{h:g} m is outside 0.5-2.2 m")
    s = height_scale(h, m)
    r = new(PASSIVE)
    r["on"] = 1.0
    for k, t in enumerate(m.terms):
        da, fo, fc = c.groups.get(t.group, (0.0, 1.0, 1.0))
        lv = c.level
        da, fo, fc = lv * da, 1.0 + lv * (fo - 1.0), 1.0 + lv * (fc - 1.0)
        own = _OWN[t.joint]
        b = [v * (fo if i == own else fc) for i, v in enumerate(t.b)]
        r["joint"][0, k], r["sign"][0, k] = t.joint, t.sign
        r["coef"][0, k] = (t.a + da + math.log(s), *b)
        # the muscle's moment on each joint (hip, knee, ankle: phi's H, K, A) per unit
        # of its force, and its stretch's range over the checked box (at its corners)
        r["arm"][0, k] = [t.sign * b[_OWN[j]] / b[own] for j in range(3)]
        corners = [sum(bi * VALID_DEG[i][(n >> i) & 1] for i, bi in enumerate(b))
                   for n in range(8)]
        r["span"][0, k] = (min(corners), max(corners))
    r["constant"] = (np.array(m.constant) + c.level * np.array(c.constant)) * s
    r["damping"] = damping
    return r


@njit(cache=True)
def _force(c, span, pa, pk, ph):  # type: ignore[no-untyped-def]
    """A term's force (>= 0) with coefficients ``c`` (a, b_A, b_K, b_H) at Riener's
    (phi_A, phi_K, phi_H) degrees: exp(a + b . phi) while its stretch b . phi lies
    within ``span`` (its range over the checked box), on its tangent (not below zero)
    beyond."""
    x = c[1] * pa + c[2] * pk + c[3] * ph
    xc = min(max(x, span[0]), span[1])
    return math.exp(c[0] + xc) * max(0.0, 1.0 + x - xc)


@njit(cache=True)
def term_value(P, k, phi):  # type: ignore[no-untyped-def]
    """Term k's force (>= 0) at phi (3,) in Riener's degrees (:func:`_force`): its
    moment on its own joint, N m."""
    return _force(P.coef[k], P.span[k], phi[0], phi[1], phi[2])


@njit(cache=True)
def riener_phi(q, phi):  # type: ignore[no-untyped-def]
    """exoleg's joint angles q (rad) -> Riener's phi = (phi_A plantarflexion, phi_K
    flexion, phi_H flexion), degrees."""
    d = 180.0 / math.pi
    phi[0] = -q[2] * d
    phi[1] = -q[1] * d
    phi[2] = q[0] * d


@njit(cache=True)
def passive_torque(P, q, dq, out):  # type: ignore[no-untyped-def]
    """The passive joint torques (N m, exoleg's signs: + moves q +) at (q, dq) into out
    (3,): the elastic moments and the viscous damping. (Scalars only: the plant calls it
    in every stage.)"""
    R = P[0]
    if R.on == 0.0:
        out[0] = out[1] = out[2] = 0.0
        return
    d = 180.0 / math.pi
    pa, pk, ph = -q[2] * d, -q[1] * d, q[0] * d
    m0, m1, m2 = R.constant[0], R.constant[1], R.constant[2]
    for k in range(N_TERMS):
        f = _force(R.coef[k], R.span[k], pa, pk, ph)
        m0 += R.arm[k, 0] * f
        m1 += R.arm[k, 1] * f
        m2 += R.arm[k, 2] * f
    # Riener's moments flex hip and knee and plantarflex the ankle; exoleg's knee
    # flexion and ankle plantarflexion are negative q
    out[0] = m0 - R.damping[0] * dq[0]
    out[1] = -m1 - R.damping[1] * dq[1]
    out[2] = -m2 - R.damping[2] * dq[2]


@njit(cache=True)
def _passive_rows(P, q, dq, out):  # type: ignore[no-untyped-def]
    for i in range(q.shape[0]):
        passive_torque(P, q[i], dq[i], out[i])


def passive_moments(P: NDArray[np.void], q: Any, dq: Any = None) -> F64:
    """The passive joint torques (exoleg's signs), one compiled loop over the rows.

    Parameters
    ----------
    P : ndarray
        The compiled model (:func:`passive_record`).
    q : array_like
        Joint angles, rad, ``(3,)`` or ``(n, 3)``.
    dq : array_like, optional
        Joint rates for the damping, rad/s; default 0.

    Returns
    -------
    ndarray
        N m, the shape of ``q``.
    """
    qa = np.ascontiguousarray(np.atleast_2d(np.asarray(q, dtype=float)))
    da = (np.zeros_like(qa) if dq is None
          else np.ascontiguousarray(np.atleast_2d(np.asarray(dq, dtype=float))))
    out = np.empty_like(qa)
    _passive_rows(P, qa, da, out)
    return out[0] if np.ndim(q) == 1 else out
