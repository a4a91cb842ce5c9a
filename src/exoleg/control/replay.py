"""Recorded walks through the controller's gait-phase detector (``exoleg detect``).

A recording is a session log of ``exoleg run`` (its FSR counts and gyroscope as the
controller read them) or a CSV file whose header names at least ``t`` (s) and the four
sensors ``heel``, ``met1``, ``met5``, ``hallux`` (forces in N, or ADC counts), with the
optional ``gyro`` (rad/s), ``acc_x``, ``acc_y`` (m/s^2) and ``reference`` (the true
events of each sample: event bits as exoleg writes them -- IC 1, FF 2, HO 4, TO 8 --
or their names joined by ``+``, e.g. ``IC+FF``; empty for none).

The detector runs at the controller's rate: each tick reads the latest sample at or
before it, as the foot board delivers its newest reading (a zero-order hold; samples
from 50 Hz up). Forces become counts through the foot board's amplifier and ADC
(:func:`exoleg.device.sensors.fsr_counts`, without noise: a recording has its own).
The detector is the controller's own compiled update (:func:`exoleg.control.gait_phase.detect`)
with its settings from ``gait_phase.toml`` (the shipped one, or a device folder's).
"""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numba import njit
from numpy.typing import NDArray

from exoleg.control import gait_phase as gp
from exoleg.device.sensors import fsr_counts
from exoleg.errors import ParameterError

F64 = NDArray[np.float64]

#: The sensors' columns, in the detector's order.
SENSOR_COLUMNS = ("heel", "met1", "met5", "hallux")
#: Columns a recording may have besides ``t`` and the sensors.
OPTIONAL_COLUMNS = ("gyro", "acc_x", "acc_y", "reference")
#: The events' short names (the CSV's and the output's), in bit order.
EVENT_CODES = {gp.Event.IC: "IC", gp.Event.FF: "FF", gp.Event.HO: "HO", gp.Event.TO: "TO"}
#: The slowest sample rate read, Hz (the detector's debounce is 8 ms; below 50 Hz a
#: sample spans more than two of them).
MIN_RATE_HZ = 50.0
#: The largest recording read: 500 MB, some 5 hours of a 1 kHz, 8-column CSV.
MAX_BYTES = 500 << 20
#: The longest recording replayed, s (at 1 kHz, 14.4 million ticks).
MAX_DURATION_S = 4 * 3600.0
#: Plausible readings: forces (N; a child's whole weight on one sensor is under 1 kN, a
#: recording's offset may dip a little below zero) and ADC counts (12 bit).
FORCE_RANGE = (-20.0, 5000.0)
COUNTS_RANGE = (0.0, 4095.0)


@dataclass(frozen=True)
class Recording:
    """A recording at the controller's rate: tick times ``t`` (s), FSR counts (n, 4),
    the gyroscope (rad/s) and the accelerometer (n, 2: x, y, m/s^2; NaN where none), the
    true events per tick (bits; None where none were given), what it was read from and
    at what rate, and the unassisted foot's insole's counts."""

    t: F64
    counts: F64
    gyro: F64
    accel: F64
    reference: NDArray[np.int64] | None
    source: str
    rate_hz: float
    #: the unassisted foot's insole (n, 4, counts; NaN where none: a CSV, or a session
    #: of a device without it)
    other: F64 | None = None


def _event_bits(where: str, row: int, text: str) -> int:
    """A reference cell: event bits (0-15) or names joined by '+' (empty: none)."""
    text = text.strip()
    if not text:
        return 0
    try:
        x = float(text)
    except ValueError:
        bits = 0
        codes = {v: int(k) for k, v in EVENT_CODES.items()}
        for name in text.split("+"):
            if name.strip().upper() not in codes:
                raise ParameterError(where, "reference", f"row {row}: {text[:20]!r} is not "
                                     "an event (IC, FF, HO, TO joined by '+', or bits "
                                     "0-15)") from None
            bits |= codes[name.strip().upper()]
        return bits
    if not (x.is_integer() and 0 <= x <= 15):
        raise ParameterError(where, "reference", f"row {row}: {text[:20]!r} is not event "
                             "bits (0-15: IC 1, FF 2, HO 4, TO 8)")
    return int(x)


def _read_csv(path: Path, counts: bool
              ) -> tuple[F64, F64, F64, F64, NDArray[np.int64] | None]:
    """(t, sensors (N, 4) as recorded, gyro (N,), accelerometer (N, 2), reference bits
    (N,) or None)."""
    from exoleg.io import read_text

    where = str(path)
    text = read_text(path, "recorded walk (CSV)", MAX_BYTES)
    rows = csv.reader(text.splitlines())
    try:
        header = [h.strip() for h in next(rows)]
    except StopIteration:
        raise ParameterError(where, "(header)", "the file is empty; expected a header "
                             "row naming t, " + ", ".join(SENSOR_COLUMNS)) from None
    for name in ("t", *SENSOR_COLUMNS):
        if name not in header:
            raise ParameterError(where, name, "no such column (the header must name t, "
                                 + ", ".join(SENSOR_COLUMNS) + "; optional "
                                 + ", ".join(OPTIONAL_COLUMNS) + ")")
    dup = sorted({h for h in header if header.count(h) > 1})
    if dup:
        raise ParameterError(where, dup[0], "named twice in the header")
    idx = {h: i for i, h in enumerate(header)}
    numeric = ["t", *SENSOR_COLUMNS] + [c for c in ("gyro", "acc_x", "acc_y") if c in idx]
    values: dict[str, list[float]] = {c: [] for c in numeric}
    ref: list[int] = []
    lo, hi = COUNTS_RANGE if counts else FORCE_RANGE
    for r, row in enumerate(rows, start=2):
        if not row or all(not c.strip() for c in row):
            continue
        if len(row) != len(header):
            raise ParameterError(where, "(row)", f"row {r} has {len(row)} fields, the header "
                                 f"{len(header)}")
        for c in numeric:
            cell = row[idx[c]].strip()
            try:
                x = float(cell)
            except ValueError:
                raise ParameterError(where, c, f"row {r}: {cell[:20]!r} is not a number"
                                     ) from None
            if not math.isfinite(x):
                raise ParameterError(where, c, f"row {r}: {cell[:20]!r} is not a finite "
                                     "number")
            if c in SENSOR_COLUMNS and not lo <= x <= hi:
                unit = "counts" if counts else "N"
                raise ParameterError(where, c, f"row {r}: {x:g} {unit} is outside "
                                     f"{lo:g}-{hi:g} {unit}" + ("" if counts else
                                     " (ADC counts? give --counts)"))
            values[c].append(x)
        if "reference" in idx:
            ref.append(_event_bits(where, r, row[idx["reference"]]))
    t = np.array(values["t"])
    if len(t) < 2:
        raise ParameterError(where, "t", f"{len(t)} samples; a walk needs at least two")
    if np.any(np.diff(t) <= 0):
        k = int(np.argmax(np.diff(t) <= 0)) + 3
        raise ParameterError(where, "t", f"row {k}: the times must increase")
    late = np.diff(t) > 1.0 / MIN_RATE_HZ + 1e-9
    if np.any(late):
        i = int(np.argmax(late))  # the first sample too late
        k = i + 3
        raise ParameterError(where, "t", f"row {k}: {(t[i + 1] - t[i]) * 1e3:.4g} ms after the "
                             f"last sample; samples must come at {MIN_RATE_HZ:g} Hz or "
                             f"faster ({1e3 / MIN_RATE_HZ:g} ms apart at most)")
    sensors = np.stack([np.array(values[c]) for c in SENSOR_COLUMNS], axis=1)
    return t, sensors, *_imu_columns(values, len(t)), (
        np.array(ref, dtype=np.int64) if "reference" in idx else None)


def _imu_columns(cols: Any, n: int) -> tuple[F64, F64]:
    """The gyroscope (n,) and the accelerometer (n, 2) of a recording's columns, NaN
    where it has none."""
    nan = np.full(n, np.nan)
    gyro = np.asarray(cols["gyro"], dtype=float) if "gyro" in cols else nan
    acc = np.stack([np.asarray(cols[c], dtype=float) if c in cols else nan
                    for c in ("acc_x", "acc_y")], axis=1)
    return gyro, acc


def _read_log(path: Path) -> tuple[F64, F64, F64, F64, F64]:
    """(t, FSR counts (N, 4), gyro, accelerometer (N, 2), the unassisted foot's insole's
    counts (N, 4; NaN where the log has none)) of a session log."""
    from exoleg.session_log import read_log

    _, cols, _ = read_log(path)
    where = str(path)
    for name in ("t", *(f"fsr_{s}" for s in SENSOR_COLUMNS)):
        if name not in cols:
            raise ParameterError(where, name, "no such column in this session log")
    t = cols["t"]
    if len(t) < 2:
        raise ParameterError(where, "t", f"{len(t)} ticks recorded; a walk needs at least two")
    bad = ~np.isfinite(t) | np.r_[False, np.diff(t) <= 0]
    if bad.any():
        k = int(np.argmax(bad))
        raise ParameterError(where, "t", f"tick {k}: {t[k]:.6g} s does not follow "
                             f"{t[k - 1]:.6g} s; a log's times are finite and increase"
                             if k else f"tick 0: {t[0]:.6g} s is not a finite time")
    counts = np.stack([cols[f"fsr_{s}"] for s in SENSOR_COLUMNS], axis=1)
    nan = np.full(len(t), np.nan)
    other = np.stack([cols.get(f"fsr_other_{s}", nan) for s in SENSOR_COLUMNS], axis=1)
    return t, counts, *_imu_columns(cols, len(t)), other


def is_session_log(path: Path) -> bool:
    from exoleg.io import check_regular
    from exoleg.session_log import MAGIC

    p = path / "session.log" if path.is_dir() else path
    try:  # a pipe, device or socket is no log (its reader says what it is)
        check_regular(p, "session log")
    except ParameterError:
        return False
    try:
        with p.open("rb") as f:
            return f.read(len(MAGIC)) == MAGIC
    except OSError:
        return False


def read_recording(path: str | Path, counts: bool = False, control_dt: float = 1e-3,
                   device: str | Path | None = None) -> Recording:
    """A recording (a session log or a CSV, see the module) at the controller's rate.
    ``counts``: the CSV's sensor columns are ADC counts, not forces."""
    from exoleg.device.sensors import FootSensors

    p = Path(path)
    if p.is_dir() and not (p / "session.log").exists():
        raise ParameterError(str(p), "(file)", "is a folder with no session.log; expected a "
                             "session (its folder or its session.log) or a CSV")
    if p.is_dir() or is_session_log(p):  # a session's folder: its log, or what is wrong
        t, c, gyro, acc, other = _read_log(p)
        ref = None
    else:
        t, raw, gyro, acc, ref = _read_csv(p, counts)
        other = np.full((len(t), 4), np.nan)
        c = raw if counts else counts_of(FootSensors.default(0.0, device).record(),
                                         np.ascontiguousarray(raw))
    if t[-1] - t[0] > MAX_DURATION_S:
        raise ParameterError(str(p), "t", f"spans {(t[-1] - t[0]) / 3600:.3g} h; a recording "
                             f"is at most {MAX_DURATION_S / 3600:g} h (split it)")
    ticks = t[0] + control_dt * np.arange(int(math.floor((t[-1] - t[0]) / control_dt + 1e-9))
                                          + 1)
    k = np.searchsorted(t, ticks + 1e-12, side="right") - 1   # the latest sample
    reference = None
    if ref is not None:
        reference = np.zeros(len(ticks), dtype=np.int64)
        near = np.clip(np.rint((t - t[0]) / control_dt).astype(np.int64), 0, len(ticks) - 1)
        for i in np.flatnonzero(ref):
            reference[near[i]] |= ref[i]
    return Recording(t=ticks, counts=c[k], gyro=gyro[k], accel=acc[k], reference=reference,
                     source=str(p), rate_hz=1.0 / float(np.median(np.diff(t))),
                     other=other[k])


def detect_events(rec: Recording, expected_stride: float = 1.1,
                  device: str | Path | None = None) -> NDArray[np.int64]:
    """The detector's event bits per tick over the recording (its state fresh at the
    start: the running maxima at the calibration floor, no stride yet; its clock the
    time since the recording's start, as the controller's from a session's)."""
    from exoleg.device.sensors import FSR_FLOOR_N, FootSensors

    board = FootSensors.default(0.0, device)
    other = (np.full((len(rec.t), 4), np.nan) if rec.other is None
             else np.ascontiguousarray(rec.other))
    d = gp.DetectorSettings.default(device).record(
        board.counts(FSR_FLOOR_N), expected_stride, board.gyro_range, board.accel_range,
        other_foot=bool(np.isfinite(other).any()))
    out: NDArray[np.int64] = detect_all(d, gp.new_state(d), np.ascontiguousarray(rec.counts),
                                        np.ascontiguousarray(rec.gyro),
                                        np.ascontiguousarray(rec.accel), rec.t - rec.t[0],
                                        other)
    return out


@njit(cache=True)
def detect_all(d, st, counts, gyro, accel, t, other):  # type: ignore[no-untyped-def]
    """:func:`~exoleg.control.gait_phase.detect` over every tick (the FSR counts (n, 4),
    the gyroscope (n,), the accelerometer (n, 2), the unassisted foot's insole's counts
    (n, 4), NaN where none): the event bits (n,)."""
    out = np.zeros(len(t), dtype=np.int64)
    for k in range(len(t)):
        out[k] = gp.detect(d, st, counts[k], gyro[k], accel[k], t[k], other[k])
    return out


@njit(cache=True)
def counts_of(board, forces):  # type: ignore[no-untyped-def]
    """ADC counts (n, 4) of the forces (n, 4) N through the foot board, without noise."""
    out = np.empty_like(forces)
    for k in range(forces.shape[0]):
        for i in range(4):
            out[k, i] = fsr_counts(board, forces[k, i], 0.0)
    return out


def _inside(t: F64, x: Any, window: float) -> Any:
    """Whether the time(s) ``x`` lie more than ``window`` s inside the recording ``t``."""
    return (x > t[0] + window) & (x < t[-1] - window)


def event_rows(series: list[tuple[F64, NDArray[np.int64], NDArray[np.int64]]],
               window: float = 0.2) -> list[dict[str, Any]]:
    """Detected against true events over recordings ``series`` -- (t, detected bits,
    true bits) each: per event, the number of true and detected ones, the timing error
    (detected - true) mean, median and 95th percentile of its size and worst, missed and
    false rates, and the share of strides (true initial contact to the next) in which
    the detector reports it (initial contact: within ``window`` of the stride's). A
    detected event matches the nearest unmatched true event of its kind within
    ``window`` s; one left unmatched within ``window`` of the recording's first or last
    sample is neither missed nor false (its partner may lie outside the recording)."""
    rows = []
    for bit, name in gp.EVENT_NAMES.items():
        errs: list[float] = []
        n_true = n_det = missed = false = strides = covered = 0
        for t, det, true in series:
            tt = t[(true & bit) > 0]
            td = t[(det & bit) > 0]
            ic = t[(true & gp.Event.IC) > 0]
            for a, b in zip(ic[:-1], ic[1:], strict=True):
                strides += 1
                lo, hi = (a - window, a + window) if bit == gp.Event.IC else (a, b)
                covered += bool(np.any((td >= lo) & (td < hi)))
            n_true += len(tt)
            n_det += len(td)
            used = np.zeros(len(td), dtype=bool)
            for x in tt:
                cand = np.where(~used & (np.abs(td - x) <= window))[0]
                if not len(cand):
                    missed += bool(_inside(t, x, window))
                    continue
                j = cand[np.argmin(np.abs(td[cand] - x))]
                used[j] = True
                errs.append(float(td[j] - x))
            false += int((~used & _inside(t, td, window)).sum())
        e = np.array(errs)
        a = np.abs(e)
        nan = float("nan")
        rows.append({"event": name, "true": n_true, "detected": n_det,
                     "mean_error_ms": float(1e3 * e.mean()) if len(e) else nan,
                     "mean_abs_error_ms": float(1e3 * a.mean()) if len(e) else nan,
                     "median_abs_error_ms": float(1e3 * np.median(a)) if len(e) else nan,
                     "p95_abs_error_ms": float(1e3 * np.percentile(a, 95)) if len(e) else nan,
                     "worst_error_ms": float(1e3 * e[np.argmax(a)]) if len(e) else nan,
                     "missed": missed, "false": false,
                     "missed_rate": missed / n_true if n_true else nan,
                     "false_rate": false / n_det if n_det else nan,
                     "strides": strides,
                     "in_strides": covered / strides if strides else nan})
    return rows


def gait_table(t: F64, bits: NDArray[np.int64]) -> dict[str, Any]:
    """What the detected events say of the walk: the count of each event, the stride
    time (initial contact to the next: mean and SD, s) and the stance (initial contact
    to its toe off, % of the stride: mean and SD)."""
    counts = {EVENT_CODES[b]: int(((bits & b) > 0).sum()) for b in EVENT_CODES}
    ic = t[(bits & gp.Event.IC) > 0]
    to = t[(bits & gp.Event.TO) > 0]
    strides = np.diff(ic)
    stance = []
    for a, b in zip(ic[:-1], ic[1:], strict=True):
        off = to[(to > a) & (to < b)]
        if len(off):
            stance.append(100.0 * (off[0] - a) / (b - a))
    nan = float("nan")
    return {"events": counts, "strides": len(strides),
            "stride_time_mean_s": float(strides.mean()) if len(strides) else nan,
            "stride_time_sd_s": float(strides.std(ddof=1)) if len(strides) > 1 else nan,
            "stance_pct_mean": float(np.mean(stance)) if stance else nan,
            "stance_pct_sd": float(np.std(stance, ddof=1)) if len(stance) > 1 else nan}


def event_list(t: F64, bits: NDArray[np.int64]) -> list[tuple[float, str]]:
    """(t, event) per detected event, in time order (IC, FF, HO, TO within a tick)."""
    return [(float(t[k]), EVENT_CODES[b]) for k in np.flatnonzero(bits)
            for b in EVENT_CODES if bits[k] & b]
