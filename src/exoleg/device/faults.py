"""The foot board's sensor faults, as data: what the board sends instead of a channel's
reading from a time on -- the same fault injected into a closed-loop walk
(:func:`exoleg.sim.walk.simulate_walk`'s ``faults``, each tick before the controller
reads it) and replayed over recorded readings (:func:`faulted`, the detector's tables in
``exoleg validate --gait-phase``).

Channels: the four FSRs (``heel``, ``met1``, ``met5``, ``hallux``, or ``fsrs`` for all
four), the foot's gyroscope (``gyro``), its accelerometer (``accel``: x and y), or the
whole ``board``. Kinds:

* ``dead``: reads ``value`` (a failed sensor or an open cable reads 0);
* ``missing``: no reading (NaN: the board does not send it);
* ``frozen``: repeats the reading it had at ``start`` (a board that hangs);
* ``offset``: ``value`` added (a sensor preloaded by its strap);
* ``drift``: the reading times ``1 + value (t - start)`` (``value`` per second).

``value`` is a fraction of the ADC's full scale for an FSR, rad/s for the gyroscope and
m/s^2 for the accelerometer (a drift's is per second whatever the channel); readings
that a fault moves stay within the sensor's range, as the board's ADC and the IMU's
saturate.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numba import njit
from numpy.typing import NDArray

from exoleg.control.contract import SENSORS
from exoleg.device.sensors import FootSensors
from exoleg.errors import ParameterError
from exoleg.layout import F8, I8

F64 = NDArray[np.float64]

#: the board's readings a fault may touch, in the order a fault's mask holds them
READINGS = ("heel", "met1", "met5", "hallux", "gyro", "acc_x", "acc_y")
#: a channel's name -> the readings it covers
CHANNELS = {"heel": (0,), "met1": (1,), "met5": (2,), "hallux": (3,), "fsrs": (0, 1, 2, 3),
            "gyro": (4,), "accel": (5, 6), "board": (0, 1, 2, 3, 4, 5, 6)}
KINDS = ("dead", "missing", "frozen", "offset", "drift")
DEAD, MISSING, FROZEN, OFFSET, DRIFT = range(len(KINDS))
#: the most faults one run takes
MOST = 16

#: A fault as the compiled code reads it: the readings it covers (bit i: reading i of
#: :data:`READINGS`), its kind (index in :data:`KINDS`), from and until when (s), its
#: value per reading (counts, rad/s, m/s^2; a drift's per s), each reading's range
#: (lowest, highest), and what a frozen reading holds (NaN until ``start``).
FAULT = np.dtype([("mask", I8), ("kind", I8), ("start", F8), ("end", F8),
                  ("value", F8, 7), ("low", F8, 7), ("high", F8, 7), ("held", F8, 7)])


#: how a fault is written where people type it (:meth:`SensorFault.parse`)
SPEC = ("CHANNEL:KIND[@START[..END]][=VALUE], e.g. heel:dead@2, met1:offset=0.25, "
        "gyro:frozen@2..5")


@dataclass(frozen=True)
class SensorFault:
    """One fault of the foot board's sensors (see the module's text): ``channel``
    (:data:`CHANNELS`), ``kind`` (:data:`KINDS`), from ``start`` s until ``end`` s
    (``inf``: the run's end), ``value`` (the kind's)."""

    channel: str
    kind: str
    start: float = 0.0
    value: float = 0.0
    end: float = math.inf

    def __post_init__(self) -> None:
        where = "SensorFault"
        if self.channel not in CHANNELS:
            raise ParameterError(where, "channel", f"{self.channel!r} is not one of "
                                 f"{', '.join(CHANNELS)}")
        if self.kind not in KINDS:
            raise ParameterError(where, "kind", f"{self.kind!r} is not one of "
                                 f"{', '.join(KINDS)}")
        for name in ("start", "value"):
            if not math.isfinite(getattr(self, name)):
                raise ParameterError(where, name, f"{getattr(self, name)!r} is not finite")
        if not (self.start >= 0.0 and self.end > self.start):
            raise ParameterError(where, "start/end", f"expected 0 <= start < end, got "
                                 f"{self.start:g}, {self.end:g}")
        fsr = max(CHANNELS[self.channel]) < 4
        if not -1.0 <= self.value <= 1.0 and (self.kind == "drift" or fsr):
            what = "per s, a drift's" if self.kind == "drift" else "of the FSRs' full scale"
            raise ParameterError(where, "value", f"{self.value:g} is outside -1-1 (a "
                                 f"fraction {what})")

    @classmethod
    def parse(cls, text: str) -> SensorFault:
        """A fault written as :data:`SPEC` (times in s) -- as ``--sensor-fault`` takes it;
        anything else refused naming what was wrong and how to write it."""
        def bad(problem: str) -> ParameterError:
            return ParameterError("sensor fault", repr(text), f"{problem}; write {SPEC}")

        head, _, value = text.partition("=")
        head, _, when = head.partition("@")
        channel, sep, kind = head.partition(":")
        if not sep:
            raise bad("no ':' between the channel and the kind")
        start, _, end = when.partition("..")
        try:
            numbers = [float(x) if x.strip() else d
                       for x, d in ((start, 0.0), (end, math.inf), (value, 0.0))]
        except ValueError:
            raise bad("a time or value is not a number") from None
        try:
            return cls(channel.strip(), kind.strip(), numbers[0], numbers[2], numbers[1])
        except ParameterError as e:
            raise bad(f"{e.field}: {e.problem}") from None

    def __str__(self) -> str:
        what = {"dead": f"reads {self.value:g}", "missing": "no reading",
                "frozen": "frozen", "offset": f"offset {self.value:+g}",
                "drift": f"drifting {self.value:+g}/s"}[self.kind]
        until = "" if math.isinf(self.end) else f" until {self.end:g} s"
        return f"{self.channel} {what} from {self.start:g} s{until}"


def fault_records(faults: Sequence[SensorFault], board: FootSensors) -> NDArray[np.void]:
    """``faults`` as the compiled code reads them (:data:`FAULT`, one record each; an
    empty array for none) on the foot ``board``: FSR values in its ADC's counts, its
    ranges the readings' limits."""
    if len(faults) > MOST:
        raise ParameterError("faults", "count", f"{len(faults)} faults; at most {MOST}")
    adc_counts = float(2**board.adc_bits - 1)
    gyro_range, accel_range = board.gyro_range, board.accel_range
    scale = np.array([adc_counts] * 4 + [1.0] * 3)
    low = np.array([0.0] * 4 + [-gyro_range] + [-accel_range] * 2)
    high = np.array([adc_counts] * 4 + [gyro_range] + [accel_range] * 2)
    out = np.zeros(len(faults), FAULT)
    for r, f in zip(out, faults, strict=True):
        r["mask"] = sum(1 << i for i in CHANNELS[f.channel])
        r["kind"] = KINDS.index(f.kind)
        r["start"], r["end"] = f.start, f.end
        r["value"] = f.value if f.kind == "drift" else f.value * scale
        r["low"], r["high"] = low, high
        r["held"] = np.nan
    return out


@njit(cache=True)
def apply_faults(F, sk, t):  # type: ignore[no-untyped-def]
    """The faults ``F`` (:data:`FAULT`, updated: a frozen reading's hold) applied at time
    ``t`` s to the board's readings in ``sk`` (:data:`~exoleg.control.contract.SENSORS`,
    one record)."""
    o = sk[0]
    for j in range(F.shape[0]):
        f = F[j]
        if t < f.start or t >= f.end:
            continue
        for i in range(7):
            if not (f.mask >> i) & 1:
                continue
            x = o.fsr[i] if i < 4 else (o.gyro if i == 4 else o.accel[i - 5])
            if f.kind == DEAD:
                y = f.value[i]
            elif f.kind == MISSING:
                y = np.nan
            elif f.kind == FROZEN:
                if math.isnan(f.held[i]):
                    f.held[i] = x
                y = f.held[i]
            elif f.kind == OFFSET:
                y = x + f.value[i]
            else:
                y = x * (1.0 + f.value[i] * (t - f.start))
            if f.kind != MISSING:
                y = min(max(y, f.low[i]), f.high[i])
            if i < 4:
                o.fsr[i] = y
            elif i == 4:
                o.gyro = y
            else:
                o.accel[i - 5] = y


@njit(cache=True)
def _faulted(F, S, t):  # type: ignore[no-untyped-def]
    for k in range(S.shape[0]):
        apply_faults(F, S[k:k + 1], t[k])


def faulted(faults: Sequence[SensorFault], counts: F64, gyro: F64, accel: F64, t: F64,
            board: FootSensors) -> tuple[F64, F64, F64]:
    """Recorded readings -- FSR ``counts`` (n, 4), ``gyro`` (n,), ``accel`` (n, 2) at
    times ``t`` (n,) -- as the foot ``board`` would have sent them with ``faults``; new
    arrays."""
    S = np.zeros(len(t), SENSORS)
    S["fsr"], S["gyro"], S["accel"] = counts, gyro, accel
    _faulted(fault_records(faults, board), S, np.asarray(t, dtype=F8))
    return S["fsr"].copy(), S["gyro"].copy(), S["accel"].copy()


__all__ = ["CHANNELS", "FAULT", "KINDS", "SPEC", "SensorFault", "apply_faults", "fault_records",
           "faulted"]
