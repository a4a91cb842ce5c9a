"""The ``exoleg`` command line: a thin layer over the library.

Bad options exit with status 2 and a one-line message.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence


def _table(rows: list[list[str]], header: list[str]) -> str:
    widths = [max(len(r[i]) for r in [header, *rows]) for i in range(len(header))]
    line = "  ".join("-" * w for w in widths)
    fmt = "  ".join(f"{{:<{w}}}" for w in widths)
    return "\n".join([fmt.format(*header), line, *(fmt.format(*r) for r in rows)])


def cmd_validate(args: argparse.Namespace) -> int:
    from exoleg.validate.checks import missing_engines, run_all

    checks = run_all(quick=args.quick)
    rows = [[c.name, c.reference, f"{c.figure:.2e}",
             (f"[{c.lower:g}, {c.tolerance:g}]" if c.lower is not None else f"<= {c.tolerance:.0e}"),
             "pass" if c.passed else "FAIL", c.detail] for c in checks]
    print(_table(rows, ["check", "reference", "figure", "tolerance", "", "detail"]))
    for m in missing_engines():
        print(f"skipped: {m} is not installed (pip install exoleg[validate])")
    failed = [c for c in checks if not c.passed]
    print(f"\n{len(checks) - len(failed)} passed, {len(failed)} failed")
    return 1 if failed else 0


def build_parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(prog="exoleg", description="Pediatric single-leg exoskeleton: "
                                 "model, control, simulation (Sarajchi & Sirlantzis 2023).")
    sub = ap.add_subparsers(dest="command", required=True)
    v = sub.add_parser("validate", help="check the model against the paper, Pinocchio, MuJoCo")
    v.add_argument("--quick", action="store_true", help="fewer random legs and states")
    v.set_defaults(func=cmd_validate)
    return ap


def main(argv: Sequence[str] | None = None) -> int:
    ap = build_parser()
    args = ap.parse_args(argv)
    from exoleg.errors import ExolegError

    try:
        return int(args.func(args))
    except ExolegError as e:
        print(f"exoleg: error: {e}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    raise SystemExit(main())
