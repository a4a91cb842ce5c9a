"""Assist-as-needed: the walking controller's support adapted to the child, stride by stride.

Emken, Benitez & Reinkensmeyer 2007's law per gait-phase bin and joint: at each initial
contact the support s of every bin the stride passed through becomes

    s <- clip(f s + g w(e), s_min, s_max),   w(e) = max(0, e - deadband)

with e the bin's RMS tracking error over the stride just walked (rad, the device's
reference against the measured angle) and f < 1 the forgetting: inside the deadband --
the natural variability -- the support decays as f^k, outside it grows with the error.
The support is the impedance's share of the torque, the transparent law's the rest
(:mod:`exoleg.control.transparency`): ``tau = s tau_impedance + (1 - s) tau_transparent``,
so support 1 is the paper's impedance and 0 the device transparent. Each stride's new
values are ramped in over ``ramp`` s from the initial contact (never a step), within
the operator's bounds; the safety layer acts after, always. Between bins the support is
interpolated along the cycle. For the device to leave the work to a child who learns,
it must relax faster than the child adapts: 1 - f above the child's learning rate
(Emken et al. 2007).

The second law (``law = "proportional"``), OpenExo's proportional joint-moment control
(Gasparri, Luque & Lerner 2019): the device transparent (support 0) and asked to put
on the child, in stance, a torque proportional to the forefoot's load,

    tau_set = peak m max(0, n - threshold) / (1 - threshold),   tau = K tau_set

(n the forefoot's load over its running maximum; peak
N m/kg per joint, signed as the joints are; m the body mass), the cuffs' torque fed
back toward it (:func:`~exoleg.control.transparency.transparent_torque`). At each
initial contact the gain K adapts to what the cuffs delivered: K <- clip(K + max tau_set
/ max tau_meas - 1, gain_min, gain_max) over the stride just walked (no cuffs' sensor,
or nothing delivered: K stays).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numba import njit
from numpy.typing import NDArray

from exoleg import checks as _check
from exoleg.entry import ASSIST_LAWS
from exoleg.errors import ParameterError
from exoleg.layout import F8, I8, new

F64 = NDArray[np.float64]

#: the gait-phase bins of the cycle (Emken et al. 2007 adapt per step phase)
BINS = 20
#: The laws (the file's ``law``): Emken's error-based one, OpenExo's proportional one
#: (its index, which the compiled tick reads, :data:`PROPORTIONAL`).
LAWS = ASSIST_LAWS
PROPORTIONAL = LAWS.index("proportional")
#: (field in the file, unit, lower, upper) of the settings
_SCALARS = (("forgetting", "", 0.0, 1.0), ("ramp_s", "s", 0.0, 2.0))
_VECTORS = (("gain_per_rad", 0.0, 100.0), ("deadband_deg", 0.0, 30.0),
            ("support_min", 0.0, 1.0), ("support_max", 0.0, 1.0),
            ("start", 0.0, 1.0))
#: The proportional law's table ``[proportional]``: (field, unit, lower, upper).
_PROPORTIONAL = (("threshold", "", 0.0, 0.95), ("gain_min", "", 0.1, 1.0),
                 ("gain_max", "", 1.0, 3.0))


@dataclass(frozen=True)
class AssistSettings:
    """The assist-as-needed law's settings (``data/device/assist.toml``): which law
    (:data:`LAWS`); the error law's forgetting f per stride, error gain g (1/rad),
    deadband (rad), the support's bounds (the operator's, which the walking controller
    keeps as tunable) and its value at the start (per joint, 0-1), and the ramp of a
    stride's new values (s); the proportional law's peak (N m/kg per joint, signed), the
    forefoot's threshold (0-1) and the gain's clip."""

    forgetting: float
    gain: F64
    deadband: F64
    support_min: F64
    support_max: F64
    start: F64
    ramp: float
    law: str = "error"
    peak: F64 = dataclasses.field(default_factory=lambda: np.zeros(3))
    threshold: float = 0.25
    gain_min: float = 0.75
    gain_max: float = 1.25

    def __post_init__(self) -> None:
        w = "AssistSettings"
        for (_, unit, lo, hi), name in zip(_SCALARS, ("forgetting", "ramp"), strict=True):
            _check.within(w, name, getattr(self, name), lo, hi, unit)
        if self.forgetting >= 1.0:
            raise ParameterError(w, "forgetting", f"{self.forgetting:g} (below 1: the "
                                 "support must forget)")
        for (_, lo, hi), name, scale in zip(
                _VECTORS, ("gain", "deadband", "support_min", "support_max", "start"),
                (1.0, 180.0 / np.pi, 1.0, 1.0, 1.0), strict=True):
            object.__setattr__(self, name, _check.vector_within(
                w, name, list(getattr(self, name)), 3, lo, hi, scale))
        if np.any(self.support_min > self.support_max):
            raise ParameterError(w, "support_min", f"{self.support_min.tolist()} above "
                                 f"support_max {self.support_max.tolist()}")
        if self.law not in LAWS:
            raise ParameterError(w, "law", f"{self.law!r} (allowed: {', '.join(LAWS)})")
        object.__setattr__(self, "peak", _check.vector_within(w, "peak", list(self.peak),
                                                              3, -2.0, 2.0))
        for name, unit, lo, hi in _PROPORTIONAL:
            _check.within(w, name, _check.finite(w, name, getattr(self, name)), lo, hi, unit)

    @classmethod
    def default(cls, folder: str | Path | None = None) -> AssistSettings:
        """From ``assist.toml`` (a device folder's, :mod:`exoleg.device.files`, or the
        package's)."""
        from exoleg.device.files import load

        where, d = load("assist.toml", folder)
        _check.keys(where, d, ["law", *(f[0] for f in (*_SCALARS, *_VECTORS)),
                               "proportional"], ["source"])
        x = {name: _check.finite(where, name, d[name]) for name, *_ in _SCALARS}
        v = {name: _check.vector(where, name, d[name], 3) for name, *_ in _VECTORS}
        pt = d["proportional"]
        if not isinstance(pt, dict):
            raise ParameterError(where, "proportional", "expected a table (peak_Nm_per_kg, "
                                 "threshold, gain_min, gain_max)")
        pw = f"{where} [proportional]"
        _check.keys(pw, pt, ["peak_Nm_per_kg", *(f[0] for f in _PROPORTIONAL)], ["source"])
        peak = _check.vector(pw, "peak_Nm_per_kg", pt["peak_Nm_per_kg"], 3)
        p = {n: _check.finite(pw, n, pt[n]) for n, *_ in _PROPORTIONAL}
        try:
            return cls(forgetting=x["forgetting"], gain=v["gain_per_rad"],
                       deadband=np.radians(v["deadband_deg"]), support_min=v["support_min"],
                       support_max=v["support_max"], start=v["start"], ramp=x["ramp_s"],
                       law=str(d["law"]), peak=peak, **p)
        except ParameterError as e:  # a range checked by the record: name the file
            raise ParameterError(where, e.field, e.problem) from None

    def with_law(self, law: str) -> AssistSettings:
        """These settings with the law ``law`` (:data:`LAWS`)."""
        return dataclasses.replace(self, law=law)

    def record(self, body_mass: float) -> NDArray[np.void]:
        """What the compiled tick reads (:data:`ASSIST`) for a child of ``body_mass`` kg
        (the proportional law's torque is per kg)."""
        r = new(ASSIST)
        r["mass"] = _check.positive("AssistSettings.record", "body_mass", body_mass, "kg")
        for name in ("forgetting", "gain", "deadband", "ramp", "peak", "threshold",
                     "gain_min", "gain_max"):
            r[name] = getattr(self, name)
        r["law"] = LAWS.index(self.law)
        return r

    def first_level(self) -> F64:
        """The support per joint (0-1) the law gives before its first stride: the error
        law's start, the proportional law's floor (the device transparent), within the
        bounds."""
        if self.law == "proportional":
            return self.support_min.copy()
        return np.clip(self.start, self.support_min, self.support_max)

    def state(self) -> NDArray[np.void]:
        """The law's state before the first stride: every bin at ``start``, within the
        bounds; the proportional law's gain 1."""
        s = new(ASSIST_STATE)
        s["support"] = s["before"] = np.clip(self.start, self.support_min, self.support_max)
        s["t_update"] = -1.0
        s["k"] = 1.0
        return s


#: The law's parameters (:meth:`AssistSettings.record`): which (:data:`LAWS`' index); the
#: error law's f, g (1/rad), deadband (rad) and ramp (s); the proportional law's peak
#: (N m/kg per joint), threshold and gain clip, and the child's body mass (kg).
ASSIST = np.dtype([("law", I8), ("forgetting", F8), ("gain", F8, 3), ("deadband", F8, 3),
                   ("ramp", F8), ("peak", F8, 3), ("threshold", F8), ("gain_min", F8),
                   ("gain_max", F8), ("mass", F8)])
#: Its state: the support per bin and joint now and before the last update (0-1), the
#: stride's squared errors and ticks per bin, when the last update came (s; negative:
#: none), the strides adapted over; the proportional law's gain K per joint and the
#: stride's peak torque asked (tau_set, unscaled) and delivered (the cuffs'), N m, along
#: each joint's sign of peak, and the forefoot's largest load so far (counts).
ASSIST_STATE = np.dtype([("support", F8, (BINS, 3)), ("before", F8, (BINS, 3)),
                         ("sq", F8, (BINS, 3)), ("n", I8, BINS), ("t_update", F8),
                         ("strides", I8), ("k", F8, 3), ("set_peak", F8, 3),
                         ("meas_peak", F8, 3), ("fore_max", F8)])


@njit(cache=True)
def assist_track(as_, x, err):  # type: ignore[no-untyped-def]
    """Add this tick's tracking error ``err`` (3,) rad at the gait fraction ``x`` to its
    bin's sums (:data:`ASSIST_STATE` ``as_``)."""
    S = as_[0]
    b = min(int(x * BINS), BINS - 1)
    S.n[b] += 1
    for j in range(3):
        S.sq[b, j] += err[j] * err[j]


@njit(cache=True)
def assist_stride(ap, as_, t, lo, hi):  # type: ignore[no-untyped-def]
    """A stride ended at ``t`` s (an initial contact). The error law: every bin it passed
    through takes Emken's update within the operator's bounds ``lo``, ``hi`` (3,); the
    proportional law: each joint's gain K adapts to the stride's peaks. The sums start
    again."""
    P = ap[0]
    S = as_[0]
    r = _ramped(ap, as_, t)
    for b in range(BINS):
        for j in range(3):
            # from where a ramp under way has got to
            S.before[b, j] += r * (S.support[b, j] - S.before[b, j])
            if S.n[b] > 0:
                e = np.sqrt(S.sq[b, j] / S.n[b])
                s = P.forgetting * S.before[b, j] + P.gain[j] * max(0.0, e - P.deadband[j])
                S.support[b, j] = min(max(s, lo[j]), hi[j])
            else:
                S.support[b, j] = S.before[b, j]
            S.sq[b, j] = 0.0
        S.n[b] = 0
    for j in range(3):
        # OpenExo: K <- clip(K + max tau_set / max tau_meas - 1); nothing delivered (or no
        # sensor): K stays
        if S.set_peak[j] > 0.0 and S.meas_peak[j] > 0.0:
            k = S.k[j] + S.set_peak[j] / S.meas_peak[j] - 1.0
            S.k[j] = min(max(k, P.gain_min), P.gain_max)
        S.set_peak[j] = 0.0
        S.meas_peak[j] = 0.0
    S.t_update = t
    S.strides += 1


@njit(cache=True)
def assist_moment(ap, as_, fore, stance, tau_int, out):  # type: ignore[no-untyped-def]
    """The proportional law's torque at the cuffs (N m) into ``out`` (3,): K tau_set,
    tau_set = peak m max(0, n - threshold) / (1 - threshold) in ``stance`` (0 else; m
    the child's mass, the record's), n the forefoot's load ``fore``
    (:func:`~exoleg.control.gait_phase.forefoot`) over its running maximum (OpenExo's
    calibration of its toe sensor); the stride's peaks of tau_set and, while tau_set is
    asked, of the cuffs' torque ``tau_int`` (NaN: no sensor) along each peak's sign, kept
    for the gain's update."""
    P = ap[0]
    S = as_[0]
    S.fore_max = max(S.fore_max, fore)
    a = 0.0
    if stance and S.fore_max > 0.0:
        a = max(0.0, fore / S.fore_max - P.threshold) / (1.0 - P.threshold)
    for j in range(3):
        tau_set = P.peak[j] * P.mass * a
        out[j] = S.k[j] * tau_set
        sign = 1.0 if P.peak[j] >= 0.0 else -1.0
        S.set_peak[j] = max(S.set_peak[j], sign * tau_set)
        if a > 0.0 and math.isfinite(tau_int[j]):  # while it is asked
            S.meas_peak[j] = max(S.meas_peak[j], sign * tau_int[j])


@njit(cache=True)
def _ramped(ap, as_, t):  # type: ignore[no-untyped-def]
    """How far (0-1) the last update has been ramped in at ``t`` s."""
    S = as_[0]
    if S.t_update >= 0.0 and ap[0].ramp > 0.0:
        return min(max((t - S.t_update) / ap[0].ramp, 0.0), 1.0)
    return 1.0


@njit(cache=True)
def assist_level(ap, as_, x, t, lo, hi, out):  # type: ignore[no-untyped-def]
    """The support per joint (0-1) at the gait fraction ``x`` and ``t`` s into ``out``
    (3,): the error law's bins' values ramped in, interpolated between the bins' centres
    along the cycle, within the operator's bounds ``lo``, ``hi`` (3,); the proportional
    law's 0 (the device transparent, the assist its torque), within the same bounds."""
    S = as_[0]
    if ap[0].law == PROPORTIONAL:
        for j in range(3):
            out[j] = lo[j]
        return
    r = _ramped(ap, as_, t)
    f = x * BINS - 0.5
    b0 = int(np.floor(f))
    a = f - b0
    i0 = b0 % BINS
    i1 = (b0 + 1) % BINS
    for j in range(3):
        s0 = S.before[i0, j] + r * (S.support[i0, j] - S.before[i0, j])
        s1 = S.before[i1, j] + r * (S.support[i1, j] - S.before[i1, j])
        out[j] = min(max((1.0 - a) * s0 + a * s1, lo[j]), hi[j])
