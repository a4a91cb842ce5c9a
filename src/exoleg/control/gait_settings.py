"""The gait-phase detector's settings (:mod:`exoleg.control.gait_phase`): thresholds,
times and stride rules as data (``data/device/gait_phase.toml``, a device folder's or the
package's), checked, and the record the compiled detector reads (:data:`SETTINGS`)."""

from __future__ import annotations

import math
from dataclasses import dataclass, fields
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from exoleg import checks as _check
from exoleg.errors import ParameterError
from exoleg.layout import F8, I8, new


@dataclass(frozen=True)
class DetectorSettings:
    """The detector's thresholds (normalised), times (s) and stride rules -- their values
    in ``gait_phase.toml`` alone (:meth:`default`)."""

    contact_on: float
    contact_off: float
    heel_off: float  # the heel's own: below it, the heel is unloaded
    calibration_floor: float  # N
    debounce: float
    min_swing: float
    min_stance: float
    strides_averaged: int
    stride_accept: tuple[float, float]
    gyro_turning: float  # rad/s
    gyro_swing: float  # rad/s
    gyro_swing_time: float  # s
    gyro_swing_floor: float  # rad/s
    slope_time: float  # s
    slope_floor: float  # rad/s^2
    slope_eased: float  # of the steepest
    gyro_rise: float  # rad/s
    push_depth: float  # of the stance's fastest toe-down turn
    toe_roll: float  # rad
    push_time: float  # s
    contact_fraction: float  # of the last swing's fastest
    gyro_contact: float  # rad/s
    gyro_heel_off: float  # rad/s
    gyro_still: float  # rad/s
    accel_still: float  # m/s^2
    still_time: float  # s
    impact: float  # m/s^2
    impact_ratio: float  # of the swing's largest jump
    impact_time: float  # s
    impact_swing: float  # of the swing's fastest turn
    unload_turn: float  # of the last push-off's fastest turn
    held_band: float  # of the held sensor's span
    held_time: float  # s
    held_swing: float  # of the stride
    frozen_time: float  # s
    fsr_silent_strides: float
    other_bears: float = 0.1  # of the other foot's span of load
    other_full: float = 0.4  # of it: the other foot in single support
    imu_slow_stride: float = 1.5  # s: from this planned stride the IMU alone waits for ...
    imu_toe_eased: float = 0.6  # ... the toe-down turn eased to this of its deepest

    def __post_init__(self) -> None:
        w = "DetectorSettings"
        if not 0.0 < self.contact_off < self.contact_on < 1.0:
            raise ParameterError(w, "contact_on/contact_off",
                                 f"need 0 < off < on < 1, got on {self.contact_on}, off "
                                 f"{self.contact_off}")
        if not 0.0 < self.heel_off < self.contact_on:
            raise ParameterError(w, "heel_off", f"need 0 < heel_off < contact_on "
                                 f"({self.contact_on:g}), got {self.heel_off}")
        for name, hi in (("debounce", 0.2), ("min_swing", 2.0), ("min_stance", 2.0)):
            v = _check.finite(w, name, getattr(self, name))
            if not 0.0 <= v <= hi:
                raise ParameterError(w, name, f"{v:g} s is outside 0-{hi:g} s")
        for name, lo, hi in (("gyro_turning", 0.0, 20.0), ("gyro_swing", 0.5, 30.0),
                             ("gyro_swing_time", 0.0, 0.5), ("gyro_swing_floor", 0.1, 30.0),
                             ("slope_time", 0.0, 0.1),
                             ("slope_floor", 0.0, 1e3), ("slope_eased", 0.01, 0.99),
                             ("gyro_rise", 0.0, 5.0), ("push_depth", 0.1, 1.0),
                             ("toe_roll", 0.0, 1.0), ("push_time", 0.0, 0.5),
                             ("contact_fraction", 0.0, 1.0), ("gyro_contact", 0.0, 20.0),
                             ("gyro_heel_off", 0.0, 20.0), ("gyro_still", 0.0, 5.0),
                             ("accel_still", 0.0, 50.0), ("still_time", 0.0, 0.5),
                             ("impact", 0.0, 1e3), ("impact_ratio", 1.0, 100.0),
                             ("impact_time", 1e-3, 0.1),
                             ("impact_swing", 0.0, 1.0), ("unload_turn", 0.05, 1.0),
                             ("held_band", 0.0, 0.5), ("held_time", 1e-3, 0.5),
                             ("held_swing", 0.1, 1.0),
                             ("frozen_time", 0.01, 10.0),
                             ("fsr_silent_strides", 1.0, 10.0),
                             ("imu_slow_stride", 0.4, 10.0), ("imu_toe_eased", 0.1, 1.0)):
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
            "gyro_swing_dps": (30.0, 1800.0, "deg/s"), "gyro_swing_ms": (0.0, 500.0, "ms"),
            "gyro_swing_floor_dps": (5.0, 1800.0, "deg/s"),
            "slope_ms": (0.0, 100.0, "ms"), "slope_floor_dps2": (0.0, 6e4, "deg/s^2"),
            "slope_eased": (0.01, 0.99, ""), "contact_fraction": (0.0, 1.0, ""),
            "gyro_rise_dps": (0.0, 300.0, "deg/s"), "push_depth": (0.1, 1.0, ""),
            "toe_roll_deg": (0.0, 45.0, "deg"), "push_ms": (0.0, 500.0, "ms"),
            "gyro_contact_dps": (0.0, 1200.0, "deg/s"), "gyro_heel_off_dps": (0.0, 1200.0, "deg/s"),
            "gyro_still_dps": (0.0, 300.0, "deg/s"), "accel_still": (0.0, 50.0, "m/s^2"),
            "still_ms": (0.0, 500.0, "ms"), "impact": (0.0, 1e3, "m/s^2"),
            "impact_ratio": (1.0, 100.0, ""),
            "impact_ms": (1.0, 100.0, "ms"), "impact_swing": (0.0, 1.0, ""),
            "unload_turn": (0.05, 1.0, ""), "held_band": (0.0, 0.5, ""),
            "held_ms": (1.0, 500.0, "ms"), "held_swing": (0.1, 1.0, ""),
            "frozen_ms": (10.0, 10000.0, "ms"), "fsr_silent_strides": (1.0, 10.0, "")},
            optional=("source", "other_bears", "other_full", "imu_slow_stride_s",
                      "imu_toe_eased", "heel_off"))
        other = _check.within(where, "other_bears", d.get("other_bears", cls.other_bears),
                              0.05, 0.95, "")
        full = _check.within(where, "other_full", d.get("other_full", cls.other_full),
                             0.05, 0.95, "")
        slow = _check.within(where, "imu_slow_stride_s",
                             d.get("imu_slow_stride_s", cls.imu_slow_stride), 0.4, 10.0, "s")
        eased = _check.within(where, "imu_toe_eased", d.get("imu_toe_eased", cls.imu_toe_eased),
                              0.1, 1.0, "")
        # a folder written before the heel had its own threshold keeps what it did
        heel = _check.within(where, "heel_off", d.get("heel_off", v["contact_off"]),
                             0.005, 0.95, "")
        if full <= other:
            raise ParameterError(where, "other_full",
                                 f"{full:g} must be above other_bears ({other:g}): single "
                                 "support is more load than bearing at all")
        if "stride_accept" not in d:
            raise ParameterError(where, "stride_accept", "missing ([lower, upper] multiples)")
        acc = _check.vector(where, "stride_accept", d["stride_accept"], 2)
        try:
            return cls(contact_on=v["contact_on"], contact_off=v["contact_off"], heel_off=heel,
                       calibration_floor=v["calibration_floor_N"],
                       debounce=v["debounce_ms"] / 1e3, min_swing=v["min_swing_ms"] / 1e3,
                       min_stance=v["min_stance_ms"] / 1e3,
                       strides_averaged=int(v["strides_averaged"]),
                       stride_accept=(float(acc[0]), float(acc[1])),
                       gyro_turning=math.radians(v["gyro_turning_dps"]),
                       gyro_swing=math.radians(v["gyro_swing_dps"]),
                       gyro_swing_time=v["gyro_swing_ms"] / 1e3,
                       gyro_swing_floor=math.radians(v["gyro_swing_floor_dps"]),
                       slope_time=v["slope_ms"] / 1e3,
                       slope_floor=math.radians(v["slope_floor_dps2"]),
                       slope_eased=v["slope_eased"], contact_fraction=v["contact_fraction"],
                       gyro_rise=math.radians(v["gyro_rise_dps"]), push_depth=v["push_depth"],
                       toe_roll=math.radians(v["toe_roll_deg"]), push_time=v["push_ms"] / 1e3,
                       gyro_contact=math.radians(v["gyro_contact_dps"]),
                       gyro_heel_off=math.radians(v["gyro_heel_off_dps"]),
                       gyro_still=math.radians(v["gyro_still_dps"]),
                       accel_still=v["accel_still"], still_time=v["still_ms"] / 1e3,
                       impact=v["impact"], impact_ratio=v["impact_ratio"],
                       impact_time=v["impact_ms"] / 1e3,
                       impact_swing=v["impact_swing"], unload_turn=v["unload_turn"],
                       held_band=v["held_band"], held_time=v["held_ms"] / 1e3,
                       held_swing=v["held_swing"],
                       frozen_time=v["frozen_ms"] / 1e3,
                       fsr_silent_strides=v["fsr_silent_strides"], other_bears=other,
                       other_full=full, imu_slow_stride=slow, imu_toe_eased=eased)
        except ParameterError as e:  # a rule across fields: name the file
            raise ParameterError(where, e.field, e.problem) from None

    def record(self, floor_counts: float, expected_stride: float,
               gyro_range: float = math.inf, accel_range: float = math.inf,
               other_foot: bool = False) -> NDArray[np.void]:
        """For :func:`detect` (:data:`SETTINGS`): thresholds, times, the calibration
        floor in counts, the expected stride time, the IMU's ranges (rad/s, m/s^2: a
        reading at its range is saturated), whether the unassisted foot's insole is
        fitted (its readings are read only then)."""
        r = new(SETTINGS)
        r["other_foot"] = 1.0 if other_foot else 0.0
        for f in fields(self):  # every setting the record holds as it is
            if f.name in _RECORD_NAMES:
                r[f.name] = getattr(self, f.name)
        r["floor"], r["expected_stride"] = floor_counts, expected_stride
        r["gyro_range"], r["accel_range"] = gyro_range, accel_range
        r["accept_lo"], r["accept_hi"] = self.stride_accept
        return r


#: The detector's settings as :func:`detect` reads them (:meth:`DetectorSettings.record`):
#: thresholds (normalised), the calibration floor (ADC counts), times (s), the stride
#: rules, the stride time expected before any is measured (s), the IMU's rules (rad/s,
#: m/s^2, s) and ranges (a reading at its range is saturated), the shares of its largest
#: load above which the unassisted foot bears the body and bears it alone (single
#: support), whether its insole is fitted (1/0), and the IMU alone's slow-walking toe off
#: (from a planned stride of ``imu_slow_stride`` s: the turn eased to ``imu_toe_eased`` of its
#: deepest).
SETTINGS = np.dtype([("contact_on", F8), ("contact_off", F8), ("heel_off", F8),
                     ("floor", F8),
                     ("debounce", F8), ("min_swing", F8), ("min_stance", F8),
                     ("strides_averaged", I8), ("accept_lo", F8), ("accept_hi", F8),
                     ("expected_stride", F8), ("gyro_turning", F8), ("gyro_swing", F8),
                     ("gyro_swing_time", F8), ("gyro_swing_floor", F8),
                     ("slope_time", F8), ("slope_floor", F8), ("slope_eased", F8),
                     ("gyro_rise", F8), ("push_depth", F8), ("toe_roll", F8),
                     ("push_time", F8),
                     ("contact_fraction", F8),
                     ("gyro_contact", F8), ("gyro_heel_off", F8), ("gyro_still", F8),
                     ("accel_still", F8), ("still_time", F8), ("impact", F8),
                     ("impact_ratio", F8),
                     ("impact_time", F8), ("impact_swing", F8), ("unload_turn", F8),
                     ("held_band", F8), ("held_time", F8), ("held_swing", F8),
                     ("frozen_time", F8), ("fsr_silent_strides", F8), ("gyro_range", F8),
                     ("accel_range", F8), ("other_bears", F8), ("other_full", F8),
                     ("other_foot", F8), ("imu_slow_stride", F8), ("imu_toe_eased", F8)])
_RECORD_NAMES = frozenset(SETTINGS.names or ())
