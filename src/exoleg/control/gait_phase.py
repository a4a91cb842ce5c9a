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

An initial contact after a toe-walking approach (forefoot first) counts too.

The foot's gyroscope (its sagittal rate, rad/s), when it reads (finite, within its
range), is fused with the FSRs (foot-gyro detection: Catalfamo et al. 2010; in children
with CP, Behboodi et al. 2019):

* a foot that is not rotating is on the ground whatever the sensors under it read: toe
  off needs the foot turning faster than ``gyro_turning`` (load under the midfoot,
  between the sensors, reads as a lifted foot);
* a foot swinging forward faster than ``gyro_swing`` for ``gyro_swing_ms`` is in swing
  whatever the sensors under it read: a stance the FSRs hold on to (a sensor preloaded
  by the strap, drift) ends with a toe off there, and each sensor's reading then is its
  offset from then on (its baseline: the running calibration; a lower reading in a
  later swing lowers it).

Without the gyroscope (NaN, or at its range: saturated) the FSRs decide alone. The
state says which source decided the last toe off (``source``: :class:`Source`). The
stride time is the mean of the last ``strides_averaged`` IC-to-IC intervals that lie
within ``stride_accept`` times the expected one; the gait percentage is the time since
the last IC over it. Thresholds, hysteresis, debounce and stride rules are data
(``data/device/gait_phase.toml``); the update is compiled (:func:`detect`).
"""

from __future__ import annotations

import math
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


class Source(IntEnum):
    """What the detector's last toe off rested on."""

    FSR = 0          # the FSRs alone (no gyroscope reading)
    FSR_IMU = 1      # the FSRs, confirmed by the foot turning
    IMU = 2          # the gyroscope's swing, the FSRs still loaded (re-baselined)


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
    gyro_turning: float = 1.0      # rad/s
    gyro_swing: float = 3.0        # rad/s
    gyro_swing_time: float = 0.05  # s

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
        for name, lo, hi in (("gyro_turning", 0.0, 20.0), ("gyro_swing", 0.5, 30.0),
                             ("gyro_swing_time", 0.0, 0.5)):
            v = _check.finite(w, name, getattr(self, name))
            if not lo <= v <= hi:
                raise ParameterError(w, name, f"{v:g} is outside {lo:g}-{hi:g}")
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
            "strides_averaged": (1.0, 10.0, ""), "gyro_turning_dps": (0.0, 1200.0, "deg/s"),
            "gyro_swing_dps": (30.0, 1800.0, "deg/s"), "gyro_swing_ms": (0.0, 500.0, "ms")})
        if "stride_accept" not in d:
            raise ParameterError(where, "stride_accept", "missing ([lower, upper] multiples)")
        acc = _check.vector(where, "stride_accept", d["stride_accept"], 2)
        try:
            return cls(contact_on=v["contact_on"], contact_off=v["contact_off"],
                       calibration_floor=v["calibration_floor_N"],
                       debounce=v["debounce_ms"] / 1e3, min_swing=v["min_swing_ms"] / 1e3,
                       min_stance=v["min_stance_ms"] / 1e3,
                       strides_averaged=int(v["strides_averaged"]),
                       stride_accept=(float(acc[0]), float(acc[1])),
                       gyro_turning=math.radians(v["gyro_turning_dps"]),
                       gyro_swing=math.radians(v["gyro_swing_dps"]),
                       gyro_swing_time=v["gyro_swing_ms"] / 1e3)
        except ParameterError as e:  # a rule across fields: name the file
            raise ParameterError(where, e.field, e.problem) from None

    def record(self, floor_counts: float, expected_stride: float,
               gyro_range: float = math.inf) -> NDArray[np.void]:
        """For :func:`detect` (:data:`SETTINGS`): thresholds, times, the calibration
        floor in counts, the expected stride time, the gyroscope's range (rad/s: a
        reading at it is saturated)."""
        r = new(SETTINGS)
        for name in ("contact_on", "contact_off", "debounce", "min_swing", "min_stance",
                     "strides_averaged", "gyro_turning", "gyro_swing", "gyro_swing_time"):
            r[name] = getattr(self, name)
        r["floor"], r["expected_stride"] = floor_counts, expected_stride
        r["gyro_range"] = gyro_range
        r["accept_lo"], r["accept_hi"] = self.stride_accept
        return r


#: The detector's settings as :func:`detect` reads them (:meth:`DetectorSettings.record`):
#: thresholds (normalised), the calibration floor (ADC counts), times (s), the stride
#: rules and the stride time expected before any is measured (s).
SETTINGS = np.dtype([("contact_on", F8), ("contact_off", F8), ("floor", F8),
                     ("debounce", F8), ("min_swing", F8), ("min_stance", F8),
                     ("strides_averaged", I8), ("accept_lo", F8), ("accept_hi", F8),
                     ("expected_stride", F8), ("gyro_turning", F8), ("gyro_swing", F8),
                     ("gyro_swing_time", F8), ("gyro_range", F8)])
#: Strides remembered (the most :attr:`DetectorSettings.strides_averaged` allows).
HISTORY = 10
#: The detector's state: the phase (:class:`Phase`); per region (heel, forefoot) the
#: raw and the debounced loaded flags and since when the raw one differs (s, -1: it
#: does not); the times of the last initial contact and toe off (s); the strides
#: accepted; the running maxima per sensor and of their sum (counts); the accepted
#: stride times, newest first (s); each sensor's baseline (its offset, counts); since
#: when the gyroscope has read a swing (s, -1: it does not); what the last toe off
#: rested on (:class:`Source`).
STATE = np.dtype([("phase", I8), ("heel_raw", np.bool_), ("fore_raw", np.bool_),
                  ("heel", np.bool_), ("fore", np.bool_), ("heel_since", F8),
                  ("fore_since", F8), ("t_ic", F8), ("t_to", F8), ("n_stride", I8),
                  ("max", F8, 4), ("total_max", F8), ("history", F8, HISTORY),
                  ("base", F8, 4), ("swing_since", F8), ("source", I8)])


def new_state(settings: NDArray[np.void]) -> NDArray[np.void]:
    """A detector's state before its first reading: phase unknown, running maxima at the
    floor, no strides."""
    s = new(STATE)
    s["phase"] = Phase.UNKNOWN
    s["heel_since"] = s["fore_since"] = -1.0
    s["t_ic"] = s["t_to"] = -1e9
    s["max"] = settings[0]["floor"]
    s["total_max"] = settings[0]["floor"]
    s["swing_since"] = -1.0
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
def detect(d, st, counts, gyro, t):  # type: ignore[no-untyped-def]
    """One reading of the four FSRs (ADC counts: heel, met1, met5, hallux) and the foot's
    gyroscope (rad/s; NaN: none) at time t. ``d``: :data:`SETTINGS`, ``st``:
    :data:`STATE` (updated). Returns the events (bits of :class:`Event`) of this tick."""
    D = d[0]
    s = st[0]
    c = np.empty(4)
    total = 0.0
    for i in range(4):
        if counts[i] > s.max[i]:
            s.max[i] = counts[i]
        c[i] = max(counts[i] - s.base[i], 0.0)
        total += counts[i]
    if total > s.total_max:
        s.total_max = total
    base = s.base[0] + s.base[1] + s.base[2] + s.base[3]
    heel = c[0] / max(s.max[0] - s.base[0], D.floor)
    fore = max(c[1] / max(s.max[1] - s.base[1], D.floor),
               c[2] / max(s.max[2] - s.base[2], D.floor),
               c[3] / max(s.max[3] - s.base[3], D.floor))
    s.heel_raw, s.heel, s.heel_since = _region(s.heel_raw, s.heel, s.heel_since, heel,
                                               D.contact_on, D.contact_off, t, D.debounce)
    s.fore_raw, s.fore, s.fore_since = _region(s.fore_raw, s.fore, s.fore_since, fore,
                                               D.contact_on, D.contact_off, t, D.debounce)
    h = s.heel
    f = s.fore
    # the whole foot unloaded, too: a load spread over several sensors, each below its own
    # threshold, is still a foot on the ground
    lifted = (total - base) / max(s.total_max - base, D.floor) < D.contact_off
    gyro_ok = math.isfinite(gyro) and abs(gyro) < D.gyro_range
    turning = not gyro_ok or abs(gyro) > D.gyro_turning
    swinging = False
    if gyro_ok and gyro > D.gyro_swing:
        if s.swing_since < 0.0:
            s.swing_since = t
        swinging = t - s.swing_since >= D.gyro_swing_time - 1e-12
    else:
        s.swing_since = -1.0
    phase = s.phase
    if phase == Phase.SWING:  # a reading in swing is at most the sensor's offset
        for i in range(4):
            if counts[i] < s.base[i]:
                s.base[i] = counts[i]
    ev = 0
    if phase <= Phase.SWING:  # swing or unknown
        if (h or f) and (phase == Phase.UNKNOWN or t - s.t_to >= D.min_swing) \
                and not swinging:
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
        to = -1
        if not h and not f and lifted and turning:
            to = Source.FSR_IMU if gyro_ok else Source.FSR
        elif swinging:  # the gyroscope reads a swing the FSRs do not
            to = Source.IMU
        if to >= 0 and t - s.t_ic >= D.min_stance:
            ev |= Event.TO
            s.t_to = t
            s.source = to
            phase = Phase.SWING
            if to == Source.IMU:  # the FSRs' readings now are their offsets
                for i in range(4):
                    s.base[i] = counts[i]
                s.heel = s.fore = s.heel_raw = s.fore_raw = False
                s.heel_since = s.fore_since = -1.0
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
