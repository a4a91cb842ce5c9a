"""The ``exoleg`` command line: a thin layer over the library.

Bad options exit with status 2 and a one-line message.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any, NoReturn

import numpy as np


class _Parser(argparse.ArgumentParser):
    """argparse, but an error is one line (``exoleg: error: ...``) and exit status 2."""

    def error(self, message: str) -> NoReturn:
        self.exit(2, f"exoleg: error: {message}\n")


def _table(rows: list[list[str]], header: list[str]) -> str:
    widths = [max(len(r[i]) for r in [header, *rows]) for i in range(len(header))]
    line = "  ".join("-" * w for w in widths)
    fmt = "  ".join(f"{{:<{w}}}" for w in widths)
    return "\n".join([fmt.format(*header), line, *(fmt.format(*r) for r in rows)])


def _floats(text: str, n: int | None = None) -> list[float]:
    try:
        vals = [float(v) for v in text.replace(" ", "").split(",") if v != ""]
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected comma-separated numbers, got {text!r}") from None
    if n is not None and len(vals) != n:
        raise argparse.ArgumentTypeError(f"expected {n} comma-separated numbers, got {text!r}")
    if not all(np.isfinite(vals)):
        raise argparse.ArgumentTypeError(f"numbers must be finite, got {text!r}")
    return vals


def _three(text: str) -> list[float]:
    return _floats(text, 3)


def _postures(text: str) -> list[list[float]]:
    return [_floats(p, 3) for p in text.split(";") if p.strip()]


class _Progress:
    """A one-line progress bar on stderr (only when stderr is a terminal)."""

    def __init__(self) -> None:
        self.tty = sys.stderr.isatty()

    def __call__(self, stage: str, fraction: float) -> None:
        if not self.tty:
            return
        n = int(30 * fraction)
        sys.stderr.write(f"\r{stage:<10} [{'#' * n}{'.' * (30 - n)}] {100 * fraction:5.1f}%")
        if fraction >= 1.0:
            sys.stderr.write("\n")
        sys.stderr.flush()


# --------------------------------------------------------------------------- validate
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


# --------------------------------------------------------------------------- simulate
def _build(args: argparse.Namespace) -> dict[str, Any]:
    """Leg, controller, reference and run settings from the options (raises ExolegError)."""
    import exoleg
    from exoleg.control import PD, ComputedTorque, PDGravity
    from exoleg.reference import MinJerk, Reference, SchwartzGait2008, Steps
    from exoleg.sim import scenario

    leg = exoleg.load_leg(args.leg) if args.leg else exoleg.paper_leg("simplified")
    sat = True if args.saturate else None
    if args.controller == "pd-gravity":
        ctrl = PDGravity(leg, args.kp, args.kd, saturation=sat)
    elif args.controller == "pd":
        ctrl = PD(args.kp, args.kd, saturation=sat)
    else:
        ctrl = ComputedTorque(leg, args.kp or [400.0] * 3, args.kd or [40.0] * 3, saturation=sat)
    changes = None
    ref: Reference
    if args.reference in ("paper", "steps", "minjerk"):
        default = scenario.paper_reference()
        times = np.array(args.times) if args.times else default.times
        post = np.radians(args.postures) if args.postures else default.postures
        ref = (MinJerk if args.reference == "minjerk" else Steps)(times, post)
        if args.reference != "minjerk":
            changes = ref.times
    else:
        ref = SchwartzGait2008(stride_time=args.stride_time, speed=args.speed, sd=args.sd)
    q0 = np.radians(args.q0) if args.q0 is not None else (
        np.zeros(3) if args.reference == "paper" else None)
    detailed = exoleg.paper_leg("detailed") if (args.reference == "paper" and not args.leg) else None
    return {"leg": leg, "controller": ctrl, "reference": ref, "q0": q0, "detailed": detailed,
            "changes": changes if changes is not None else [0.0]}


def _summary_rows(figs: dict[str, Any], paper_like: bool) -> list[list[str]]:
    rows = []
    if "detailed_vs_simplified_max_deg" in figs:
        rows.append(["detailed (2x torque) vs simplified, max deg",
                     f"{figs['detailed_vs_simplified_max_deg']:.2e}", "1e-13 (Fig. 13D)"])
    for k, v in figs.items():
        if k.startswith("exoleg_vs_"):
            rows.append([f"exoleg vs {k[10:-8]}, max deg", f"{v:.2e}", "1e-11 (Fig. 13E)"])
    errs = figs["tracking_error_at_segment_ends_deg"]
    rows.append(["tracking error at segment ends, max deg", f"{max(errs):.2e}",
                 "1e-6 (Fig. 13F)" if paper_like else "-"])
    rows.append(["verification dq^T(Mdot-2C)dq, max |W|", f"{figs['verification_max_abs']:.1e}",
                 "1e-16 (Fig. 14)"])
    rows.append(["   relative to |dq^T Mdot dq|", f"{figs['verification_relative']:.1e}", "-"])
    rows.append(["V (eq 26) largest rise within a segment, J",
                 f"{figs['lyapunov_max_rise_within_segments_J']:.1e}",
                 "0 in continuous time (eq 30)"])
    rows.append(["sampled-loop margin h*lambda(M^-1 Kd)", f"{figs['sampled_stability_h_lambda']:.3f}",
                 "< 2 stable"])
    rows.append(["steps with saturated torque", str(figs["saturated_steps"]), "-"])
    return rows


def cmd_simulate(args: argparse.Namespace) -> int:
    from exoleg.sim.scenario import run_scenario

    t0 = time.perf_counter()
    cfg = _build(args)
    progress = _Progress()
    report = run_scenario(cfg["leg"], cfg["controller"], cfg["reference"], args.duration,
                          dt=args.dt, control_dt=1.0 / args.control_rate, q0=cfg["q0"],
                          detailed=cfg["detailed"], engine=None if args.no_engine else "mujoco",
                          changes=cfg["changes"], progress=progress)
    figs = report.figures()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    series = (report.result.to_parquet(out / "timeseries.parquet") if args.format == "parquet"
              else report.result.to_csv(out / "timeseries.csv"))
    from exoleg.plots import animate, save_figures

    paths = save_figures(report, out, ("png", "svg") if args.svg else ("png",))
    if args.animate:
        progress("animation", 0.0)
        paths.append(animate(cfg["leg"], report.result.t, report.result.q, out / "gait.mp4",
                             q_ref=report.result.q_ref))
        progress("animation", 1.0)
    summary = {
        "settings": {k: (v if not isinstance(v, np.ndarray) else v.tolist())
                     for k, v in vars(args).items() if k != "func"},
        "leg": cfg["leg"].name,
        "figures": figs,
        "notes": report.notes,
        "files": [str(series), *map(str, paths)],
        "wall_time_s": time.perf_counter() - t0,
    }
    (out / "summary.json").write_text(json.dumps(summary, indent=2, default=str))

    print(f"exoleg simulate: {args.reference} reference, {args.controller} controller, "
          f"{args.duration:g} s at dt = {args.dt:g} s, control {args.control_rate:g} Hz, "
          f"leg '{cfg['leg'].name}'")
    print()
    print(_table(_summary_rows(figs, args.reference == "paper"), ["figure", "exoleg", "paper"]))
    print()
    prow = [[r["joint"], f"{r['torque_Nm']:.1f} / {r['torque_limit_Nm']:.0f}",
             f"{r['speed_deg_s']:.0f} / {r['speed_limit_deg_s']:.0f}",
             f"{r['power_W']:.1f} / {r['power_limit_W']:.0f}",
             "yes" if r["within_limits"] else "NO"] for r in figs["peaks"]]
    print(_table(prow, ["joint", "peak torque / limit N m", "speed / limit deg/s",
                        "power / limit W", "within Table 2"]))
    for n in report.notes:
        print(f"note: {n}")
    print(f"\nwrote {out}/: {Path(series).name}, summary.json, "
          + ", ".join(p.name for p in paths) + f"  ({summary['wall_time_s']:.1f} s)")
    return 0


# --------------------------------------------------------------------------- parser
def _positive(text: str) -> float:
    v = _floats(text, 1)[0]
    if v <= 0:
        raise argparse.ArgumentTypeError(f"must be > 0, got {text}")
    return v


def build_parser() -> argparse.ArgumentParser:
    ap = _Parser(prog="exoleg", description="Pediatric single-leg exoskeleton: model, control, "
                 "simulation (Sarajchi & Sirlantzis, Sensors 2023).")
    sub = ap.add_subparsers(dest="command", required=True, parser_class=_Parser)
    v = sub.add_parser("validate", help="check the model against the paper, Pinocchio, MuJoCo")
    v.add_argument("--quick", action="store_true", help="fewer random legs and states")
    v.set_defaults(func=cmd_validate)

    s = sub.add_parser("simulate", help="closed-loop simulation; default: the paper's scenario")
    s.add_argument("--reference", choices=["paper", "steps", "minjerk", "gait"], default="paper",
                   help="paper: its 3 s step schedule with normative stance/swing postures")
    s.add_argument("--postures", type=_postures,
                   help="steps/minjerk postures, deg: 'h,k,a;h,k,a;...' (knee flexion < 0)")
    s.add_argument("--times", type=_floats, help="steps/minjerk times, s: '0,3,6'")
    s.add_argument("--speed", default="Free",
                   choices=["VerySlow", "Slow", "Free", "Fast", "VeryFast"],
                   help="gait: Schwartz 2008 speed group")
    s.add_argument("--stride-time", type=_positive, default=1.2, help="gait: s per cycle")
    s.add_argument("--sd", type=float, default=0.0, help="gait: mean + sd * SD")
    s.add_argument("--controller", choices=["pd-gravity", "pd", "computed-torque"],
                   default="pd-gravity")
    s.add_argument("--kp", type=_three, help="gains 'hip,knee,ankle' (default: paper's)")
    s.add_argument("--kd", type=_three, help="gains 'hip,knee,ankle' (default: paper's)")
    s.add_argument("--saturate", action="store_true", help="clip torques at Table 2's limits")
    s.add_argument("--duration", type=_positive, default=12.0, help="s (default 12)")
    s.add_argument("--dt", type=_positive, default=1e-3, help="RK4 step, s (default 1e-3)")
    s.add_argument("--control-rate", type=_positive, default=1000.0, help="Hz (default 1000)")
    s.add_argument("--q0", type=_three, help="initial posture, deg 'h,k,a'")
    s.add_argument("--leg", type=Path, help="leg parameter file (TOML); default: paper Table 5")
    s.add_argument("--out", type=Path, default=Path("exoleg-out"), help="output folder")
    s.add_argument("--format", choices=["csv", "parquet"], default="csv")
    s.add_argument("--svg", action="store_true", help="also write SVG figures")
    s.add_argument("--animate", action="store_true", help="write a gait animation (MP4/GIF)")
    s.add_argument("--no-engine", action="store_true", help="skip the MuJoCo comparison")
    s.set_defaults(func=cmd_simulate)
    return ap


def main(argv: Sequence[str] | None = None) -> int:
    ap = build_parser()
    args = ap.parse_args(argv)
    from exoleg.errors import ExolegError

    try:
        return int(args.func(args))
    except (ExolegError, ImportError) as e:
        print(f"exoleg: error: {e}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    raise SystemExit(main())
