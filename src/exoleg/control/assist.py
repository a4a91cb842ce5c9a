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
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numba import njit
from numpy.typing import NDArray

from exoleg.errors import ParameterError
from exoleg.layout import F8, I8, new
from exoleg.params import _check

F64 = NDArray[np.float64]

#: the gait-phase bins of the cycle (Emken et al. 2007 adapt per step phase)
BINS = 20
#: (field in the file, unit, lower, upper) of the settings
_SCALARS = (("forgetting", "", 0.0, 1.0), ("ramp_s", "s", 0.0, 2.0))
_VECTORS = (("gain_per_rad", 0.0, 100.0), ("deadband_deg", 0.0, 30.0),
            ("support_min", 0.0, 1.0), ("support_max", 0.0, 1.0),
            ("start", 0.0, 1.0))


@dataclass(frozen=True)
class AssistSettings:
    """The assist-as-needed law's settings (``data/device/assist.toml``): the forgetting
    f per stride, the error gain g (1/rad), the deadband (rad), the support's bounds and
    its value at the start (per joint, 0-1), and the ramp of a stride's new values (s)."""

    forgetting: float
    gain: F64
    deadband: F64
    support_min: F64
    support_max: F64
    start: F64
    ramp: float

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

    @classmethod
    def default(cls, folder: str | Path | None = None) -> AssistSettings:
        """From ``assist.toml`` (a device folder's, :mod:`exoleg.device.files`, or the
        package's)."""
        from exoleg.device.files import load

        where, d = load("assist.toml", folder)
        _check.keys(where, d, [f[0] for f in (*_SCALARS, *_VECTORS)], ["source"])
        x = {name: _check.finite(where, name, d[name]) for name, *_ in _SCALARS}
        v = {name: _check.vector(where, name, d[name], 3) for name, *_ in _VECTORS}
        try:
            return cls(forgetting=x["forgetting"], gain=v["gain_per_rad"],
                       deadband=np.radians(v["deadband_deg"]), support_min=v["support_min"],
                       support_max=v["support_max"], start=v["start"], ramp=x["ramp_s"])
        except ParameterError as e:  # a range checked by the record: name the file
            raise ParameterError(where, e.field, e.problem) from None

    def record(self) -> NDArray[np.void]:
        """What the compiled tick reads (:data:`ASSIST`)."""
        r = new(ASSIST)
        for name in ("forgetting", "gain", "deadband", "ramp"):
            r[name] = getattr(self, name)
        return r

    def state(self) -> NDArray[np.void]:
        """The law's state before the first stride: every bin at ``start``, within the
        bounds."""
        s = new(ASSIST_STATE)
        s["lo"], s["hi"] = self.support_min, self.support_max
        s["support"] = s["before"] = np.clip(self.start, self.support_min, self.support_max)
        s["t_update"] = -1.0
        return s


#: The law's parameters (:meth:`AssistSettings.record`): f, g (1/rad), the deadband
#: (rad) and the ramp (s).
ASSIST = np.dtype([("forgetting", F8), ("gain", F8, 3), ("deadband", F8, 3), ("ramp", F8)])
#: Its state: the support per bin and joint now and before the last update (0-1), the
#: stride's squared errors and ticks per bin, when the last update came (s; negative:
#: none), the strides adapted over, and the operator's bounds per joint (0-1).
ASSIST_STATE = np.dtype([("support", F8, (BINS, 3)), ("before", F8, (BINS, 3)),
                         ("sq", F8, (BINS, 3)), ("n", I8, BINS), ("t_update", F8),
                         ("strides", I8), ("lo", F8, 3), ("hi", F8, 3)])


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
def assist_stride(ap, as_, t):  # type: ignore[no-untyped-def]
    """A stride ended at ``t`` s (an initial contact): every bin it passed through takes
    Emken's update within the operator's bounds; the sums start again."""
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
                S.support[b, j] = min(max(s, S.lo[j]), S.hi[j])
            else:
                S.support[b, j] = S.before[b, j]
            S.sq[b, j] = 0.0
        S.n[b] = 0
    S.t_update = t
    S.strides += 1


@njit(cache=True)
def _ramped(ap, as_, t):  # type: ignore[no-untyped-def]
    """How far (0-1) the last update has been ramped in at ``t`` s."""
    S = as_[0]
    if S.t_update >= 0.0 and ap[0].ramp > 0.0:
        return min(max((t - S.t_update) / ap[0].ramp, 0.0), 1.0)
    return 1.0


@njit(cache=True)
def assist_level(ap, as_, x, t, out):  # type: ignore[no-untyped-def]
    """The support per joint (0-1) at the gait fraction ``x`` and ``t`` s into ``out``
    (3,): the bins' values ramped in, interpolated between the bins' centres along the
    cycle, within the operator's bounds."""
    S = as_[0]
    r = _ramped(ap, as_, t)
    f = x * BINS - 0.5
    b0 = int(np.floor(f))
    a = f - b0
    i0 = b0 % BINS
    i1 = (b0 + 1) % BINS
    for j in range(3):
        s0 = S.before[i0, j] + r * (S.support[i0, j] - S.before[i0, j])
        s1 = S.before[i1, j] + r * (S.support[i1, j] - S.before[i1, j])
        out[j] = min(max((1.0 - a) * s0 + a * s1, S.lo[j]), S.hi[j])
