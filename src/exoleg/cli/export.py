"""``exoleg export``: the leg as URDF or MJCF."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from exoleg.cli._common import _say


# --------------------------------------------------------------------------- export
def cmd_export(args: argparse.Namespace) -> int:
    import exoleg
    from exoleg.cli._common import _read_leg
    from exoleg.errors import ParameterError
    from exoleg.export import writers

    if not args.out.is_dir() and args.out.suffix.lower() not in (".urdf", ".xml"):
        # a session's session.log was written over with the URDF (exit 0)
        raise ParameterError("exoleg export", "--out", f"{args.out.name}: the leg is written "
                             "as a .urdf or .xml file (name one; nothing else is written "
                             "over)")
    if args.leg and args.variant is not None:
        raise ParameterError("exoleg export", "--variant", "chooses the paper's leg: not "
                             "with --leg (the file is the leg)")
    leg = (_read_leg(args.leg, refuse_unfit="exoleg export")[0] if args.leg
           else exoleg.paper_leg(args.variant or "detailed"))
    fmt = args.format or ("mjcf" if args.out.suffix == ".xml" else "urdf")
    write = writers.write_mjcf if fmt == "mjcf" else writers.write_urdf
    path = write(leg, args.out, mode=args.mode, frame=args.frame)
    _say(f"wrote {path} ({fmt.upper()}, {args.mode}, {args.frame}, leg '{leg.name}')")
    return 0


def add_parser(sub: Any) -> None:
    """Add ``exoleg export`` to the subcommands ``sub``."""
    e = sub.add_parser("export", help="write the leg as URDF or MJCF (limits, actuators, "
                       "geometry)")
    e.add_argument("--leg", type=Path, help="leg parameter file (default: the paper's leg)")
    e.add_argument("--variant", choices=["simplified", "detailed"],
                   help="the paper's leg when no --leg (default detailed)")
    e.add_argument("--format", choices=["urdf", "mjcf"],
                   help="default: from the suffix (.xml -> mjcf, else urdf)")
    e.add_argument("--mode", choices=["lumped", "welded"], default="lumped")
    e.add_argument("--frame", choices=["y-up", "z-up"], default="y-up",
                   help="y-up: exoleg's frame; z-up: for ROS tools (REP 103)")
    e.add_argument("--out", type=Path, required=True, help="file to write")
    e.set_defaults(func=cmd_export)
