"""``exoleg detect``: a recorded walk through the controller's gait-phase detector."""

from __future__ import annotations

import argparse
import math
from pathlib import Path
from typing import Any

from exoleg.cli._common import STRIDE_TIME_RANGE, _say, _table, _within


def _ms(x: float) -> str:
    return "-" if math.isnan(x) else f"{x:+.0f}"


def cmd_detect(args: argparse.Namespace) -> int:
    import pyarrow as pa

    from exoleg.control.replay import (
        detect_events,
        event_list,
        event_rows,
        gait_table,
        read_recording,
    )
    from exoleg.errors import ParameterError
    from exoleg.io import atomic_path, write_csv_table

    out = Path(args.out)
    if not out.is_dir() and out.suffix.lower() != ".csv":  # a session's session.log was
        raise ParameterError("exoleg detect", "--out", f"{out.name}: the events are a CSV "
                             "(name a .csv file; a session's own records are never written "
                             "over)")
    if out.exists() and out.resolve() == Path(args.file).resolve():
        raise ParameterError("exoleg detect", "--out", f"{out} is the recording being read: "
                             "name another file (nothing was written)")
    rec = read_recording(args.file, counts=args.counts, device=args.device)
    bits = detect_events(rec, args.stride, args.device)
    events = event_list(rec.t, bits)
    table = pa.table({"t": pa.array([e[0] for e in events], pa.float64()),
                      "event": pa.array([e[1] for e in events], pa.string())})
    with atomic_path(out) as tmp:
        write_csv_table(table, tmp)
    g = gait_table(rec.t, bits)
    _table([[k, str(v)] for k, v in g["events"].items()]
           + [["strides", str(g["strides"])],
              ["stride time", f"{g['stride_time_mean_s']:.3f} s (SD {g['stride_time_sd_s']:.3f})"],
              ["stance", f"{g['stance_pct_mean']:.1f} % of the stride (SD "
                         f"{g['stance_pct_sd']:.1f})"]],
           ["", "detected"], title=f"{rec.source}: {len(rec.t)} ticks at the controller's "
           f"1 kHz from samples at {rec.rate_hz:.0f} Hz")
    if rec.reference is not None:
        rows = event_rows([(rec.t, bits, rec.reference)])
        _table([[r["event"], str(r["true"]), str(r["detected"]), _ms(r["mean_error_ms"]),
                 _ms(r["median_abs_error_ms"]), _ms(r["p95_abs_error_ms"]),
                 _ms(r["worst_error_ms"]), str(r["missed"]), str(r["false"])] for r in rows],
               ["event", "true", "detected", "mean error ms", "median |error| ms",
                "p95 |error| ms", "worst ms", "missed", "extra"],
               title="against the reference column")
    _say(f"wrote {out} ({len(events)} events)")
    return 0


def add_parser(sub: Any) -> None:
    """Add ``exoleg detect`` to the subcommands ``sub``."""
    d = sub.add_parser(
        "detect", help="run the gait-phase detector over a recorded walk",
        description="Run the controller's gait-phase detector over a recorded walk: a "
        "session log of `exoleg run`, or a CSV whose header names t (s), heel, met1, met5, "
        "hallux (forces in N, or ADC counts with --counts), optionally gyro (rad/s), acc_x, "
        "acc_y (m/s^2) and reference (the true events: bits IC 1, FF 2, HO 4, TO 8, or "
        "names joined by '+'), sampled at 50 Hz or faster. Writes one row per event "
        "(t, event), prints the walk's events, stride time and stance, and with a reference "
        "column the timing errors and the missed and extra events.")
    d.add_argument("file", type=Path, help="the recording (session.log, its folder, or a CSV)")
    d.add_argument("--out", type=Path, required=True, help="the events' CSV to write")
    d.add_argument("--counts", action="store_true",
                   help="the CSV's sensor columns are 12-bit ADC counts, not forces in N")
    d.add_argument("--stride", type=_within(*STRIDE_TIME_RANGE, " s"), default=1.1,
                   help="the stride time expected before the first is measured, s "
                        "(default 1.1)")
    d.add_argument("--device", type=Path, metavar="DIR",
                   help="a device folder whose gait_phase.toml and "
                   "sensors.toml replace the shipped ones")
    d.set_defaults(func=cmd_detect)

