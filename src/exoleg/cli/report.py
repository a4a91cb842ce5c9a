"""``exoleg report SESSION``: the session report a clinic can file (PDF)."""

from __future__ import annotations

import argparse
import time
from pathlib import Path
from typing import Any

from exoleg.cli._common import _say


def cmd_report(args: argparse.Namespace) -> int:
    from exoleg.errors import ParameterError
    from exoleg.hmi.history import history_until
    from exoleg.plots.report import write_report

    out = args.out or args.session / "report.pdf"
    if out.suffix.lower() != ".pdf":
        raise ParameterError("exoleg report", "--out", f"{out.name}: a report is a PDF "
                             "(name a .pdf file; a session's own records are never "
                             "written over)")
    t0 = time.perf_counter()
    write_report(args.session, out, name=args.name, history=history_until(args.session))
    _say(f"wrote {out} ({time.perf_counter() - t0:.1f} s)")
    return 0


def add_parser(sub: Any) -> None:
    """Add ``exoleg report`` to the subcommands ``sub``."""
    r = sub.add_parser("report", help="a session's report for the clinic's file (PDF)")
    r.add_argument("session", type=Path, help="the session's folder (exoleg run --out, or "
                   "the console's sessions folder's)")
    r.add_argument("--out", type=Path, help="the PDF to write (default SESSION/report.pdf)")
    r.add_argument("--name", action="store_true", help="name the child (by default only "
                   "their pseudonymous id, as the console's records keep it)")
    r.set_defaults(func=cmd_report)
