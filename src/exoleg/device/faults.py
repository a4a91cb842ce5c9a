"""The foot board's sensor faults, as data: what the board sends instead of a channel's
reading from a time on -- the same fault injected into a closed-loop walk
(:func:`exoleg.sim.walk.simulate_walk`'s ``faults``, each tick before the controller
reads it) and replayed over recorded readings (:func:`faulted`, the detector's tables in
``exoleg validate --gait-phase``).

Channels: the four FSRs (``heel``, ``met1``, ``met5``, ``hallux``, or ``fsrs`` for all
four), the foot's gyroscope (``gyro``), its accelerometer (``accel``: x and y), the
unassisted foot's ``insole`` (its four FSRs, read on the board's spare ADC channels:
``sensors.toml [other_foot]``), or the whole ``board`` (all of them). Kinds:

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
from enum import IntEnum

import numpy as np
from numba import njit
from numpy.typing import NDArray

from exoleg.device.sensors import FootSensors
from exoleg.errors import ParameterError
from exoleg.layout import F8, I8
from exoleg.tick import SENSOR_POINTS, SENSORS

F64 = NDArray[np.float64]

#: the fields of a tick's readings (:data:`~exoleg.control.contract.SENSORS`) the foot
#: board sends, and a fault may touch
BOARD_FIELDS = ("fsr", "gyro", "accel", "fsr_other")
#: a channel's name -> the (field, slot) pairs it covers; slot None: the whole field (the
#: four FSRs named as :data:`~exoleg.control.contract.SENSOR_POINTS` names them)
CHANNELS: dict[str, tuple[tuple[str, int | None], ...]] = {
    **{p: (("fsr", i),) for i, p in enumerate(SENSOR_POINTS)},
    "fsrs": (("fsr", None),), "gyro": (("gyro", None),), "accel": (("accel", None),),
    "insole": (("fsr_other", None),),
    "board": tuple((n, None) for n in BOARD_FIELDS)}


class Kind(IntEnum):
    """What a fault does to a reading (see the module's text)."""

    DEAD = 0
    MISSING = 1
    FROZEN = 2
    OFFSET = 3
    DRIFT = 4


#: the kinds by name, as people write them
KINDS = tuple(k.name.lower() for k in Kind)
#: the most faults one run takes (a choice: a bound on what a run is asked, far above the
#: two at once validate --gait-phase combines)
MOST = 16

#: A fault as the compiled code reads it: its kind (:class:`Kind`), from and until when
#: (s), and per board field (:data:`BOARD_FIELDS`, shaped as in ``SENSORS``) whether it
#: covers each reading (1) or not (0), its value (counts, rad/s, m/s^2; a drift's per s),
#: what a frozen reading holds (NaN until ``start``), and the field's range (lowest,
#: highest).
FAULT = np.dtype([("kind", I8), ("start", F8), ("end", F8)]
                 + [(f"{n}_{part}", F8, SENSORS[n].shape) for n in BOARD_FIELDS
                    for part in ("on", "value", "held")]
                 + [(f"{n}_{end}", F8) for n in BOARD_FIELDS for end in ("low", "high")])


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
        fsr = all(field in ("fsr", "fsr_other") for field, _ in CHANNELS[self.channel])
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
        if value.strip() and kind.strip() in ("missing", "frozen"):
            raise bad(f"{kind.strip()} takes no value (dead, offset and drift do)")
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
    # per field: the scale of a value (an FSR's is a fraction of full scale) and the range
    ranges = {"fsr": (adc_counts, 0.0, adc_counts), "fsr_other": (adc_counts, 0.0, adc_counts),
              "gyro": (1.0, -board.gyro_range, board.gyro_range),
              "accel": (1.0, -board.accel_range, board.accel_range)}
    out = np.zeros(len(faults), FAULT)
    for r, f in zip(out, faults, strict=True):
        r["kind"] = Kind[f.kind.upper()]
        r["start"], r["end"] = f.start, f.end
        for n in BOARD_FIELDS:
            scale, r[f"{n}_low"], r[f"{n}_high"] = ranges[n]
            r[f"{n}_value"] = f.value if f.kind == "drift" else f.value * scale
            r[f"{n}_held"] = np.nan
        for n, slot in CHANNELS[f.channel]:
            if slot is None:
                r[f"{n}_on"] = 1.0
            else:
                r[f"{n}_on"][slot] = 1.0
    return out


@njit(inline="always")
def _fault(kind, x, value, held, low, high, t, start):  # type: ignore[no-untyped-def]
    """A reading ``x`` under a fault of ``kind`` at time ``t``: (what the board sends,
    what a frozen reading holds from now)."""
    if kind == Kind.MISSING:
        return np.nan, held
    if kind == Kind.DEAD:
        y = value
    elif kind == Kind.FROZEN:
        if math.isnan(held):
            held = x
        y = held
    elif kind == Kind.OFFSET:
        y = x + value
    else:
        y = x * (1.0 + value * (t - start))
    return min(max(y, low), high), held


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
        for i in range(f.fsr_on.shape[0]):
            if f.fsr_on[i] > 0.0:
                o.fsr[i], f.fsr_held[i] = _fault(f.kind, o.fsr[i], f.fsr_value[i],
                                                 f.fsr_held[i], f.fsr_low, f.fsr_high, t,
                                                 f.start)
        if f.gyro_on > 0.0:
            o.gyro, f.gyro_held = _fault(f.kind, o.gyro, f.gyro_value, f.gyro_held,
                                         f.gyro_low, f.gyro_high, t, f.start)
        for i in range(f.accel_on.shape[0]):
            if f.accel_on[i] > 0.0:
                o.accel[i], f.accel_held[i] = _fault(f.kind, o.accel[i], f.accel_value[i],
                                                     f.accel_held[i], f.accel_low,
                                                     f.accel_high, t, f.start)
        for i in range(f.fsr_other_on.shape[0]):
            if f.fsr_other_on[i] > 0.0:
                o.fsr_other[i], f.fsr_other_held[i] = _fault(
                    f.kind, o.fsr_other[i], f.fsr_other_value[i], f.fsr_other_held[i],
                    f.fsr_other_low, f.fsr_other_high, t, f.start)


@njit(cache=True)
def _faulted(F, S, t):  # type: ignore[no-untyped-def]
    for k in range(S.shape[0]):
        apply_faults(F, S[k:k + 1], t[k])


def faulted(faults: Sequence[SensorFault], counts: F64, gyro: F64, accel: F64, t: F64,
            board: FootSensors, other: F64 | None = None) -> tuple[F64, F64, F64, F64]:
    """Recorded readings -- FSR ``counts`` (n, 4), ``gyro`` (n,), ``accel`` (n, 2), the
    insole's ``other`` (n, 4; None: none, NaN) at times ``t`` (n,) -- as the foot ``board``
    would have sent them with ``faults``; new arrays (counts, gyro, accel, other)."""
    S = np.zeros(len(t), SENSORS)
    S["fsr"], S["gyro"], S["accel"] = counts, gyro, accel
    S["fsr_other"] = np.nan if other is None else other
    _faulted(fault_records(faults, board), S, np.asarray(t, dtype=F8))
    return S["fsr"].copy(), S["gyro"].copy(), S["accel"].copy(), S["fsr_other"].copy()


__all__ = ["BOARD_FIELDS", "CHANNELS", "FAULT", "KINDS", "SPEC", "Kind", "SensorFault",
           "apply_faults", "fault_records", "faulted"]
