"""Gait-phase detection from the foot board's force sensors.

Each FSR reading is normalised by its running maximum (a floor keeps an unloaded start
from dividing by nothing); the heel region is the heel sensor, the forefoot the largest
of the metatarsal and hallux sensors; toe off also needs the sum of all four under the
off threshold of its own running maximum (a load spread over several sensors, each
below its threshold, is still a foot on the ground). A region is loaded above ``contact_on`` and
unloaded below ``contact_off`` (hysteresis), and a change counts only once it has held
for ``debounce_ms``. From the two regions:

    swing --(either region loaded)--> initial contact (IC)
    IC: heel and forefoot loaded --> foot flat (FF)
    FF: heel unloaded, forefoot loaded --> heel off (HO)
    any stance phase: nothing loaded --> toe off (TO) --> swing

An initial contact after a toe-walking approach (forefoot first) counts too. The
stride time is the mean of the last ``strides_averaged`` IC-to-IC intervals that lie
within ``stride_accept`` times the expected one; the gait percentage is the time since
the last IC over it. Thresholds, hysteresis, debounce and stride rules are data
(``data/device/gait_phase.toml``); the update is compiled (:func:`detect`).
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import IntEnum
from pathlib import Path

import numpy as np
from numba import njit
from numpy.typing import NDArray

from exoleg.errors import ParameterError
from exoleg.params import _check

F64 = NDArray[np.float64]


class Phase(IntEnum):
    UNKNOWN = -1
    SWING = 0
    LOADING = 1   # initial contact to foot flat
    FLAT = 2      # foot flat to heel off
    PUSH = 3      # heel off to toe off


class Event(IntEnum):
    """Bits of a tick's events."""

    IC = 1
    FF = 2
    HO = 4
    TO = 8


EVENT_NAMES = {Event.IC: "initial contact", Event.FF: "foot flat", Event.HO: "heel off",
               Event.TO: "toe off"}


@dataclass(frozen=True)
class DetectorSettings:
    """The detector's thresholds (normalised), times (s) and stride rules."""

    contact_on: float
    contact_off: float
    calibration_floor: float  # N
    debounce: float
    min_swing: float
    min_stance: float
    strides_averaged: int
    stride_accept: tuple[float, float]

    def __post_init__(self) -> None:
        w = "DetectorSettings"
        if not 0.0 < self.contact_off < self.contact_on < 1.0:
            raise ParameterError(w, "contact_on/contact_off",
                                 f"need 0 < off < on < 1, got on {self.contact_on}, off "
                                 f"{self.contact_off}")
        for name, hi in (("debounce", 0.2), ("min_swing", 2.0), ("min_stance", 2.0)):
            v = _check.finite(w, name, getattr(self, name))
            if not 0.0 <= v <= hi:
                raise ParameterError(w, name, f"{v:g} s is outside 0-{hi:g} s")
        if not 1 <= self.strides_averaged <= 10:
            raise ParameterError(w, "strides_averaged", "must be 1-10")
        lo, hi = self.stride_accept
        if not 0.0 < lo < 1.0 < hi:
            raise ParameterError(w, "stride_accept", f"need 0 < lo < 1 < hi, got {lo}, {hi}")

    @classmethod
    def default(cls, folder: str | Path | None = None) -> DetectorSettings:
        """From ``gait_phase.toml`` (a device folder's, :mod:`exoleg.device.files`, or the
        package's)."""
        from exoleg.device.files import load

        where, d = load("gait_phase.toml", folder)
        v = _check.ranged(where, {k: x for k, x in d.items() if k != "stride_accept"}, {
            "contact_on": (0.0, 1.0, ""), "contact_off": (0.0, 1.0, ""),
            "calibration_floor_N": (0.1, 1e3, "N"), "debounce_ms": (0.0, 200.0, "ms"),
            "min_swing_ms": (0.0, 2000.0, "ms"), "min_stance_ms": (0.0, 2000.0, "ms"),
            "strides_averaged": (1.0, 10.0, "")})
        if "stride_accept" not in d:
            raise ParameterError(where, "stride_accept", "missing ([lower, upper] multiples)")
        acc = _check.vector(where, "stride_accept", d["stride_accept"], 2)
        try:
            return cls(contact_on=v["contact_on"], contact_off=v["contact_off"],
                       calibration_floor=v["calibration_floor_N"],
                       debounce=v["debounce_ms"] / 1e3, min_swing=v["min_swing_ms"] / 1e3,
                       min_stance=v["min_stance_ms"] / 1e3,
                       strides_averaged=int(v["strides_averaged"]),
                       stride_accept=(float(acc[0]), float(acc[1])))
        except ParameterError as e:  # a rule across fields: name the file
            raise ParameterError(where, e.field, e.problem) from None

    def params(self, floor_counts: float, expected_stride: float) -> F64:
        """For :func:`detect`: thresholds, times, the calibration floor in counts, the
        expected stride time."""
        return np.array([self.contact_on, self.contact_off, floor_counts, self.debounce,
                         self.min_swing, self.min_stance, float(self.strides_averaged),
                         self.stride_accept[0], self.stride_accept[1], expected_stride])


D_ON, D_OFF, D_FLOOR, D_DEBOUNCE, D_MINSW, D_MINST, D_NAVG, D_ACC_LO, D_ACC_HI, D_EXPECTED = \
    range(10)
# state layout
(S_PHASE, S_HEEL_RAW, S_FORE_RAW, S_HEEL, S_FORE, S_HEEL_SINCE, S_FORE_SINCE, S_T_IC,
 S_T_TO, S_NSTRIDE, S_MAX) = range(11)
S_TOTAL_MAX = S_MAX + 4
S_HIST = S_MAX + 5
STATE_SIZE = S_HIST + 10


def new_state(settings_params: F64) -> F64:
    """A detector's state before its first reading: phase unknown, running maxima at the
    floor, no strides."""
    s = np.zeros(STATE_SIZE)
    s[S_PHASE] = Phase.UNKNOWN
    s[S_HEEL_SINCE] = s[S_FORE_SINCE] = -1.0
    s[S_T_IC] = s[S_T_TO] = -1e9
    s[S_MAX:S_MAX + 4] = settings_params[D_FLOOR]
    s[S_TOTAL_MAX] = settings_params[D_FLOOR]
    return s


@njit(inline="always")
def _region(st, raw_i, deb_i, since_i, value, on, off, t, debounce):  # type: ignore[no-untyped-def]
    raw = value > (off if st[raw_i] > 0.5 else on)
    st[raw_i] = 1.0 if raw else 0.0
    if (st[deb_i] > 0.5) != raw:
        if st[since_i] < 0.0:
            st[since_i] = t
        if t - st[since_i] >= debounce - 1e-12:
            st[deb_i] = 1.0 if raw else 0.0
            st[since_i] = -1.0
    else:
        st[since_i] = -1.0


@njit(cache=True)
def stride_time(d, st):  # type: ignore[no-untyped-def]
    """The current stride estimate, s: the mean of the last accepted strides, or the
    expected one before any."""
    n = int(min(st[S_NSTRIDE], d[D_NAVG]))
    if n == 0:
        return d[D_EXPECTED]
    acc = 0.0
    for i in range(n):
        acc += st[S_HIST + i]
    return acc / n


@njit(cache=True)
def detect(d, st, counts, t):  # type: ignore[no-untyped-def]
    """One reading of the four FSRs (ADC counts: heel, met1, met5, hallux) at time t.
    Updates the state; returns the events (bits of :class:`Event`) of this tick."""
    for i in range(4):
        if counts[i] > st[S_MAX + i]:
            st[S_MAX + i] = counts[i]
    total = counts[0] + counts[1] + counts[2] + counts[3]
    if total > st[S_TOTAL_MAX]:
        st[S_TOTAL_MAX] = total
    heel = counts[0] / st[S_MAX]
    fore = max(counts[1] / st[S_MAX + 1], counts[2] / st[S_MAX + 2],
               counts[3] / st[S_MAX + 3])
    _region(st, S_HEEL_RAW, S_HEEL, S_HEEL_SINCE, heel, d[D_ON], d[D_OFF], t, d[D_DEBOUNCE])
    _region(st, S_FORE_RAW, S_FORE, S_FORE_SINCE, fore, d[D_ON], d[D_OFF], t, d[D_DEBOUNCE])
    h = st[S_HEEL] > 0.5
    f = st[S_FORE] > 0.5
    # the whole foot unloaded, too: a load spread over several sensors, each below its own
    # threshold, is still a foot on the ground
    lifted = total / st[S_TOTAL_MAX] < d[D_OFF]
    phase = int(st[S_PHASE])
    ev = 0
    if phase <= 0:  # swing or unknown
        if (h or f) and (phase < 0 or t - st[S_T_TO] >= d[D_MINSW]):
            ev |= 1
            dt = t - st[S_T_IC]
            expected = stride_time(d, st)
            if phase == 0 and d[D_ACC_LO] * expected <= dt <= d[D_ACC_HI] * expected:
                for i in range(9, 0, -1):
                    st[S_HIST + i] = st[S_HIST + i - 1]
                st[S_HIST] = dt
                st[S_NSTRIDE] += 1
            st[S_T_IC] = t
            if h and f:
                ev |= 2
                phase = 2
            else:
                phase = 1
    else:
        if not h and not f and lifted:
            if t - st[S_T_IC] >= d[D_MINST]:
                ev |= 8
                st[S_T_TO] = t
                phase = 0
        elif phase == 1 and h and f:
            ev |= 2
            phase = 2
        elif phase == 2 and f and not h:
            ev |= 4
            phase = 3
    st[S_PHASE] = phase
    return ev


@njit(cache=True)
def gait_fraction(d, st, t):  # type: ignore[no-untyped-def]
    """Fraction of the gait cycle since the last initial contact, in [0, 1)."""
    if st[S_T_IC] < -1e8:
        return 0.0
    x = (t - st[S_T_IC]) / stride_time(d, st)
    return min(x, 0.999999)
