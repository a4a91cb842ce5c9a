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
from exoleg.layout import F8, I8, new
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
PHASE_NAMES = {Phase.UNKNOWN: "unknown", Phase.SWING: "swing", Phase.LOADING: "loading",
               Phase.FLAT: "foot flat", Phase.PUSH: "push-off"}


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

    def record(self, floor_counts: float, expected_stride: float) -> NDArray[np.void]:
        """For :func:`detect` (:data:`SETTINGS`): thresholds, times, the calibration
        floor in counts, the expected stride time."""
        r = new(SETTINGS)
        for name in ("contact_on", "contact_off", "debounce", "min_swing", "min_stance",
                     "strides_averaged"):
            r[name] = getattr(self, name)
        r["floor"], r["expected_stride"] = floor_counts, expected_stride
        r["accept_lo"], r["accept_hi"] = self.stride_accept
        return r


#: The detector's settings as :func:`detect` reads them (:meth:`DetectorSettings.record`):
#: thresholds (normalised), the calibration floor (ADC counts), times (s), the stride
#: rules and the stride time expected before any is measured (s).
SETTINGS = np.dtype([("contact_on", F8), ("contact_off", F8), ("floor", F8),
                     ("debounce", F8), ("min_swing", F8), ("min_stance", F8),
                     ("strides_averaged", I8), ("accept_lo", F8), ("accept_hi", F8),
                     ("expected_stride", F8)])
#: Strides remembered (the most :attr:`DetectorSettings.strides_averaged` allows).
HISTORY = 10
#: The detector's state: the phase (:class:`Phase`); per region (heel, forefoot) the
#: raw and the debounced loaded flags and since when the raw one differs (s, -1: it
#: does not); the times of the last initial contact and toe off (s); the strides
#: accepted; the running maxima per sensor and of their sum (counts); the accepted
#: stride times, newest first (s).
STATE = np.dtype([("phase", I8), ("heel_raw", np.bool_), ("fore_raw", np.bool_),
                  ("heel", np.bool_), ("fore", np.bool_), ("heel_since", F8),
                  ("fore_since", F8), ("t_ic", F8), ("t_to", F8), ("n_stride", I8),
                  ("max", F8, 4), ("total_max", F8), ("history", F8, HISTORY)])


def new_state(settings: NDArray[np.void]) -> NDArray[np.void]:
    """A detector's state before its first reading: phase unknown, running maxima at the
    floor, no strides."""
    s = new(STATE)
    s["phase"] = Phase.UNKNOWN
    s["heel_since"] = s["fore_since"] = -1.0
    s["t_ic"] = s["t_to"] = -1e9
    s["max"] = settings[0]["floor"]
    s["total_max"] = settings[0]["floor"]
    return s


@njit(inline="always")
def _region(raw_was, loaded, since, value, on, off, t, debounce):  # type: ignore[no-untyped-def]
    """One region's hysteresis and debounce: (raw, loaded, since) after ``value``."""
    raw = value > (off if raw_was else on)
    if loaded != raw:
        if since < 0.0:
            since = t
        if t - since >= debounce - 1e-12:
            loaded = raw
            since = -1.0
    else:
        since = -1.0
    return raw, loaded, since


@njit(cache=True)
def stride_time(d, st):  # type: ignore[no-untyped-def]
    """The current stride estimate, s: the mean of the last accepted strides, or the
    expected one before any."""
    s = st[0]
    n = min(s.n_stride, d[0].strides_averaged)
    if n == 0:
        return d[0].expected_stride
    acc = 0.0
    for i in range(n):
        acc += s.history[i]
    return acc / n


@njit(cache=True)
def detect(d, st, counts, t):  # type: ignore[no-untyped-def]
    """One reading of the four FSRs (ADC counts: heel, met1, met5, hallux) at time t.
    ``d``: :data:`SETTINGS`, ``st``: :data:`STATE` (updated). Returns the events (bits
    of :class:`Event`) of this tick."""
    D = d[0]
    s = st[0]
    for i in range(4):
        if counts[i] > s.max[i]:
            s.max[i] = counts[i]
    total = counts[0] + counts[1] + counts[2] + counts[3]
    if total > s.total_max:
        s.total_max = total
    heel = counts[0] / s.max[0]
    fore = max(counts[1] / s.max[1], counts[2] / s.max[2], counts[3] / s.max[3])
    s.heel_raw, s.heel, s.heel_since = _region(s.heel_raw, s.heel, s.heel_since, heel,
                                               D.contact_on, D.contact_off, t, D.debounce)
    s.fore_raw, s.fore, s.fore_since = _region(s.fore_raw, s.fore, s.fore_since, fore,
                                               D.contact_on, D.contact_off, t, D.debounce)
    h = s.heel
    f = s.fore
    # the whole foot unloaded, too: a load spread over several sensors, each below its own
    # threshold, is still a foot on the ground
    lifted = total / s.total_max < D.contact_off
    phase = s.phase
    ev = 0
    if phase <= Phase.SWING:  # swing or unknown
        if (h or f) and (phase == Phase.UNKNOWN or t - s.t_to >= D.min_swing):
            ev |= Event.IC
            dt = t - s.t_ic
            expected = stride_time(d, st)
            if phase == Phase.SWING and D.accept_lo * expected <= dt <= D.accept_hi * expected:
                for i in range(HISTORY - 1, 0, -1):
                    s.history[i] = s.history[i - 1]
                s.history[0] = dt
                s.n_stride += 1
            s.t_ic = t
            if h and f:
                ev |= Event.FF
                phase = Phase.FLAT
            else:
                phase = Phase.LOADING
    else:
        if not h and not f and lifted:
            if t - s.t_ic >= D.min_stance:
                ev |= Event.TO
                s.t_to = t
                phase = Phase.SWING
        elif phase == Phase.LOADING and h and f:
            ev |= Event.FF
            phase = Phase.FLAT
        elif phase == Phase.FLAT and f and not h:
            ev |= Event.HO
            phase = Phase.PUSH
    s.phase = phase
    return ev


@njit(cache=True)
def gait_fraction(d, st, t):  # type: ignore[no-untyped-def]
    """Fraction of the gait cycle since the last initial contact, in [0, 1)."""
    if st[0].t_ic < -1e8:
        return 0.0
    x = (t - st[0].t_ic) / stride_time(d, st)
    return min(x, 0.999999)
