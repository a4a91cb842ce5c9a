"""``exoleg log summary``: what a session log holds; ``exoleg log export``: a session
for a gait lab (C3D, Motion-BIDS, CSV with units)."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from exoleg.cli._common import _Parser, _say, _table


def cmd_log_summary(args: argparse.Namespace) -> int:
    from exoleg.io import OutputFolder
    from exoleg.runtime.session import summarize, to_table

    s = summarize(args.log)
    _table([[k, _shown(k, v)] for k, v in s.items()], ["", "value"],
           title=f"session log {args.log}")
    if args.csv or args.parquet:
        from exoleg.errors import ParameterError
        from exoleg.io import write_csv_table, write_parquet_table
        from exoleg.runtime.session import SESSION_FILES

        option = "--csv" if args.csv else "--parquet"
        target = Path(args.csv or args.parquet)
        log = args.log / "session.log" if args.log.is_dir() else args.log
        if target.exists() and target.resolve() == log.resolve():
            raise ParameterError("exoleg log summary", option, f"{target} is the log "
                                 "being read: name another file (nothing was written)")
        if target.name in SESSION_FILES:
            raise ParameterError("exoleg log summary", option, f"{target.name} is the name "
                                 "of a session's own record: name another file (nothing "
                                 "was written)")
        with OutputFolder(target.parent if str(target.parent) else ".") as out:
            (write_csv_table if args.csv else write_parquet_table)(
                to_table(args.log), out.stage(target.name))
            out.commit()
        _say(f"wrote {target}")
    return 0


def _shown(key: str, value: Any) -> str:
    """A summary's value as people read it: numbers to four significant figures, the
    modes by name, per-joint figures as ``hip 25, knee 25, ankle 25``, the safety
    layer's events as their texts, nothing as ``-``."""
    from exoleg.tick import Mode, name_of

    if value is None:
        return "-"
    if isinstance(value, bool) or isinstance(value, (int, str)):
        return str(value)
    if isinstance(value, float):
        return f"{value:.4g}"
    if isinstance(value, dict):
        named = ((name_of(Mode, k) if key == "ticks_per_mode" else str(k), v)
                 for k, v in value.items())
        return ", ".join(f"{k} {_shown('', v)}" for k, v in named) or "-"
    if isinstance(value, (list, tuple)):
        if value and all(isinstance(v, dict) and "text" in v for v in value):
            return "; ".join(f"{v['text']} (from {v['first_s']:.3f} s, {v['ticks']} ticks)"
                             for v in value)
        return ", ".join(_shown("", v) for v in value) or "-"
    return str(value)


def cmd_log_export(args: argparse.Namespace) -> int:
    from exoleg.errors import ParameterError
    from exoleg.runtime.exports import session_export, write_bids, write_c3d, write_csv

    targets = [x for x in (args.c3d, args.bids, args.csv) if x is not None]
    if len(targets) != 1:
        raise ParameterError("exoleg log export", "--c3d/--bids/--csv", "give one of them "
                             "(what to write, and where)")
    for option, path, suffix in (("--c3d", args.c3d, ".c3d"), ("--csv", args.csv, ".csv")):
        if path is not None and path.suffix.lower() != suffix:
            raise ParameterError("exoleg log export", option, f"{path.name}: name a "
                                 f"{suffix} file")
    if args.bids is not None:  # a dataset of its own: not mixed into the recording's files
        session = (args.session if args.session.is_dir() else args.session.parent).resolve()
        bids = args.bids.resolve()
        if bids == session or session in bids.parents:
            raise ParameterError("exoleg log export", "--bids", f"{args.bids} is in the "
                                 "session's own folder: name a folder outside it (nothing "
                                 "was written)")
    exp = session_export(args.session, args.rate)
    if args.c3d:
        written = write_c3d(exp, args.c3d)
    elif args.bids:
        written = write_bids(exp, args.bids)
    else:
        written = [write_csv(exp, args.csv)]
    _say(f"{len(exp.channels)} channels at {exp.rate_hz:g} Hz, {len(exp.events)} events; "
         f"wrote {', '.join(str(p) for p in written)}")
    return 0


def add_parser(sub: Any) -> None:
    """Add ``exoleg log summary`` to the subcommands ``sub``."""
    lg = sub.add_parser("log", help="read a session log")
    lsub = lg.add_subparsers(dest="log_command", required=True, parser_class=_Parser)
    ls = lsub.add_parser("summary", help="what a session log holds (also a cut one)")
    ls.add_argument("log", type=Path, help="session.log, or the folder of exoleg run --out")
    ls.add_argument("--csv", type=Path, help="also write the series as CSV")
    ls.add_argument("--parquet", type=Path, help="also write the series as Parquet")
    ls.set_defaults(func=cmd_log_summary)
    le = lsub.add_parser("export", help="a session for a gait lab: C3D, Motion-BIDS or CSV "
                         "with units (joint angles in degrees, torques, events)")
    le.add_argument("session", type=Path, help="the session's folder")
    le.add_argument("--c3d", type=Path, help="write a C3D file (split every 65,535 frames)")
    le.add_argument("--bids", type=Path, help="write a Motion-BIDS dataset into this folder")
    le.add_argument("--csv", type=Path, help="write a CSV, units in its header")
    le.add_argument("--rate", type=float, help="decimate to this rate, Hz (the tick rate "
                    "divided by a whole number; each sample the mean of its ticks)")
    le.set_defaults(func=cmd_log_export)
