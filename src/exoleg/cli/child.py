"""``exoleg child``: the children in the console's records and each child's history --
their sessions over time, the figures trended, the change in their Gait Profile Score
against its minimal clinically important difference -- shown or exported."""

from __future__ import annotations

import argparse
import datetime
from pathlib import Path
from typing import Any

from exoleg.cli._common import _Parser, _say, _table


def _when(t: float) -> str:
    return datetime.datetime.fromtimestamp(t).strftime("%Y-%m-%d %H:%M")


def _support(s: dict[str, Any]) -> list[Any]:
    """A session's support mode at its end and its assistance per joint (the support
    level's mean over the gait phases walked), None where it has none."""
    from exoleg.params.records import JOINTS

    a = s["assistance"] or {}
    return [(s["settings"] or {}).get("support_mode"), *[a.get(j) for j in JOINTS]]


SUPPORT = ["support_mode", "assistance_hip", "assistance_knee", "assistance_ankle"]


def cmd_child(args: argparse.Namespace) -> int:
    from exoleg.errors import ParameterError
    from exoleg.hmi.history import TRENDED, child_history
    from exoleg.hmi.registry import FILE, Registry

    if args.child_command == "list":
        path = args.sessions / FILE
        if not path.is_file():
            raise ParameterError(str(args.sessions), FILE, "no records here (the console's "
                                 "sessions folder, exoleg hmi --sessions)")
        reg = Registry(path)
        try:
            rows = [[c["id"], c["name"] if args.name else "-", str(c["fits"]),
                     str(c["sessions"])]
                    for c in reg.children()]
        finally:
            reg.close()
        _table(rows, ["child", "name", "fits", "sessions"],
               title=f"children in {args.sessions}")
        return 0
    h = child_history(args.sessions, args.child)
    cols = ["session", "started", "operator", *TRENDED, *SUPPORT]
    rows = [[s["name"], _when(s["started"]), s["operator"] or "-",
             *["-" if x is None else x if isinstance(x, str) else f"{x:.4g}"
               for x in [*(s[k] for k in TRENDED), *_support(s)]]]
            for s in h["sessions"]]
    if args.child_command == "show":
        who = f"{h['child_id']} ({h['name']})" if args.name else h["child_id"]
        _table(rows, cols, title=f"{who}: {len(rows)} session(s)")
        if h["gps_change_deg"] is not None:
            _say(f"Gait Profile Score: {h['gps_change_deg']:+.1f} deg from the first session "
                 f"to the last -- {'beyond' if h['beyond_mcid'] else 'within'} its minimal "
                 "clinically important difference (1.6 deg, Baker et al. 2012)")
        _say(f"their next session starts with {h['settings_text']}")
        return 0
    out: Path = args.out
    if out.suffix.lower() not in (".csv", ".json"):
        raise ParameterError("exoleg child export", "--out", f"{out.name}: a .csv or .json "
                             "file")
    from exoleg.runtime.session import SESSION_FILES

    if out.name in SESSION_FILES:  # a session's run.json was written over (exit 0)
        raise ParameterError("exoleg child export", "--out", f"{out.name} is the name of a "
                             "session's own record: name another file (nothing was written)")
    from exoleg.io import atomic_path, write_json

    if out.suffix.lower() == ".json":
        write_json(out, h if args.name else {**h, "name": None})
    else:
        import csv

        with atomic_path(out) as tmp, tmp.open("w", newline="", encoding="utf-8") as f:
            w = csv.writer(f)
            w.writerow(["session", "started_utc_s", "operator", "note", *TRENDED, *SUPPORT])
            for s in h["sessions"]:
                w.writerow([s["name"], s["started"], s["operator"] or "", s["note"] or "",
                            *["" if x is None else x
                              for x in [*(s[k] for k in TRENDED), *_support(s)]]])
    _say(f"wrote {out}")
    return 0


def add_parser(sub: Any) -> None:
    """Add ``exoleg child`` to the subcommands ``sub``."""
    c = sub.add_parser("child", help="the children in the console's records and their "
                       "history (sessions, figures trended)")
    csub = c.add_subparsers(dest="child_command", required=True, parser_class=_Parser)
    for name, helptext in (("list", "the children recorded"),
                           ("show", "a child's sessions over time and the trend"),
                           ("export", "a child's history as CSV or JSON")):
        p = csub.add_parser(name, help=helptext)
        if name != "list":
            p.add_argument("child", help="the child's pseudonymous id (e.g. C3f9a01bc)")
        p.add_argument("--sessions", type=Path, default=Path("exoleg-sessions"),
                       help="the console's sessions folder (default exoleg-sessions)")
        p.add_argument("--name", action="store_true", help="show the child's name (by "
                       "default only their pseudonymous id)")
        if name == "export":
            p.add_argument("--out", type=Path, required=True, help="a .csv or .json file")
        p.set_defaults(func=cmd_child)
