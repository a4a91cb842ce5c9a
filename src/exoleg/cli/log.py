"""``exoleg log summary``: what a session log holds."""

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


def add_parser(sub: Any) -> None:
    """Add ``exoleg log summary`` to the subcommands ``sub``."""
    lg = sub.add_parser("log", help="read a session log")
    lsub = lg.add_subparsers(dest="log_command", required=True, parser_class=_Parser)
    ls = lsub.add_parser("summary", help="what a session log holds (also a cut one)")
    ls.add_argument("log", type=Path, help="session.log, or the folder of exoleg run --out")
    ls.add_argument("--csv", type=Path, help="also write the series as CSV")
    ls.add_argument("--parquet", type=Path, help="also write the series as Parquet")
    ls.set_defaults(func=cmd_log_summary)
