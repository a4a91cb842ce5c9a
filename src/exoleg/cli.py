"""The ``exoleg`` command line: a thin layer over the library.

Bad options exit with status 2 and a one-line message.
"""

from __future__ import annotations

import argparse
import gc
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


def _prepare_worker() -> None:
    from exoleg.sim.closed_loop import warm_up

    warm_up()
    import exoleg.plots.figures  # noqa: F401


def _save_figures(report: Any, out: Path, formats: tuple[str, ...]) -> list[Path]:
    from exoleg.plots.figures import save_figures

    paths = save_figures(report, out, formats)
    gc.freeze()  # this worker's last task: let it exit without a final collection (see run)
    return paths


def cmd_simulate(args: argparse.Namespace) -> int:
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor

    from exoleg.sim.scenario import run_scenario

    t0 = time.perf_counter()
    cfg = _build(args)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    progress = _Progress()
    # A second process compiles the kernels the scenario needs besides the stepper and
    # imports matplotlib while this one compiles the stepper and simulates, then draws the
    # figures while this one writes the time series (two cores, half the wait). On Linux
    # it is forked, before MuJoCo is loaded, and so starts with this process's imports
    # (0.5-0.8 s sooner than a spawned one); elsewhere it is spawned.
    method = "fork" if sys.platform == "linux" else "spawn"
    with ProcessPoolExecutor(1, mp_context=multiprocessing.get_context(method)) as pool:
        prepared = pool.submit(_prepare_worker)
        report = run_scenario(cfg["leg"], cfg["controller"], cfg["reference"], args.duration,
                              dt=args.dt, control_dt=1.0 / args.control_rate, q0=cfg["q0"],
                              detailed=cfg["detailed"],
                              engine=None if args.no_engine else "mujoco",
                              changes=cfg["changes"], progress=progress)
        drawn = pool.submit(_save_figures, report, out, ("png", "svg") if args.svg else ("png",))
        figs = report.figures()
        series = (report.result.to_parquet(out / "timeseries.parquet")
                  if args.format == "parquet" else report.result.to_csv(out / "timeseries.csv"))
        if args.animate:
            from exoleg.plots import animate

            progress("animation", 0.0)
            movie = animate(cfg["leg"], report.result.t, report.result.q, out / "gait.mp4",
                            q_ref=report.result.q_ref)
            progress("animation", 1.0)
        prepared.result()  # (a failure there is a bug: let it show)
        paths = drawn.result()
    if args.animate:
        paths.append(movie)
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


# --------------------------------------------------------------------------- fit
def cmd_fit(args: argparse.Namespace) -> int:
    import dataclasses
    import warnings

    import exoleg
    from exoleg.sizing import Child, fit_device, personalized_leg
    from exoleg.sizing.demand import actuator_demand

    measured = {k: (getattr(args, k) / 100 if getattr(args, k) is not None else None)
                for k in ("thigh", "shank", "leg_length", "foot_length", "ankle_height")}
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        child = Child(age=args.age, sex=args.sex, height=args.height / 100, mass=args.mass,
                      gmfcs=None if args.gmfcs == 0 else args.gmfcs, affected_side=args.side,
                      name=args.name, **measured)
    for w in caught:
        print(f"warning: {w.message}")
    fit = fit_device(child, args.leg_length_method)
    leg = personalized_leg(child, fit)
    demand = actuator_demand(child, leg, percentile=args.percentile, speed=args.speed,
                             stride_time=args.stride_time, simulate=not args.no_simulate)
    d = fit.dimensions
    print(f"{child.name}: {child.age:g} y {child.sex}, {child.height * 100:.1f} cm, "
          f"{child.mass:.1f} kg, {'GMFCS ' + str(child.gmfcs) if child.gmfcs else 'TD'} "
          f"({child.chart} chart)\n")
    print(_table([[k, f"{getattr(d, k) * 100:.1f}", d.sources[k]] for k in
                  ("thigh", "shank", "ankle_height", "foot_length", "leg_length")],
                 ["dimension", "cm", "source"]))
    print(f"\nverdict: {'FITS' if fit.fits else 'DOES NOT FIT'}")
    print(f"  upper telescope (hip-knee) {fit.upper * 100:.1f} cm (27-40), lower telescope "
          f"(knee-sole) {fit.lower * 100:.1f} cm (33-46), footplate 23.5 cm")
    for m in fit.misses:
        print(f"  misses: {m.what}: child {m.child * 100:.1f} cm, allowed "
              f"{m.allowed[0] * 100:.1f}-{m.allowed[1] * 100:.1f} cm, by {m.by * 100:+.2f} cm")
    pr = fit.paper_rule
    print(f"  paper's Table 1 rule: leg length {pr['leg_length'] * 100:.1f} cm vs 60-86 cm -> "
          f"{'fits' if pr['fits'] else 'does not fit'}")
    rom = fit.range_of_motion
    print("  normative gait range (mean +- 2 SD) vs device range of motion, deg: " + ", ".join(
        f"{j} {np.degrees(rom['gait_lower'][i]):.0f}..{np.degrees(rom['gait_upper'][i]):.0f} in "
        f"{np.degrees(rom['device_lower'][i]):.0f}..{np.degrees(rom['device_upper'][i]):.0f}"
        for i, j in enumerate(("hip", "knee", "ankle"))))
    units = {"torque": ("N m", 1.0), "speed": ("deg/s", 180 / np.pi), "power": ("W", 1.0)}
    rows = []
    for r in demand.table():
        u, k = units[r["quantity"]]
        rows.append([r["source"], f"{r['quantity']} ({u})"] + [
            f"{r[j] * k:.1f} ({r[j + '_margin']:.2f})" for j in ("hip", "knee", "ankle")])
    lim = demand.limits
    rows.append(["Table 2 limits", "torque / speed / power"] + [
        f"{lim[0, j]:.0f} / {np.degrees(lim[1, j]):.0f} / {lim[2, j]:.0f}" for j in range(3)])
    print("\nactuator demand (margin = limit / demand):")
    print(_table(rows, ["source", "quantity", "hip", "knee", "ankle"]))
    mg, src, qn, joint = demand.smallest_margin()
    print(f"\nsmallest margin: {mg:.2f} ({qn} at the {joint}, {src})")
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    header = (f"personalized leg of {child.name} ({child.age:g} y {child.sex}, "
              f"{child.height:.3f} m, {child.mass:.1f} kg) made by exoleg fit")
    exoleg.save_leg(leg, out / "leg.toml", header=header)
    report = {"child": dataclasses.asdict(child), "chart": child.chart,
              "dimensions_m": dataclasses.asdict(d), "fits": fit.fits,
              "settings_m": {"upper": fit.upper, "lower": fit.lower},
              "link_lengths_m": list(fit.link_lengths),
              "misses": [dataclasses.asdict(m) for m in fit.misses],
              "paper_rule": pr, "demand": demand.table(),
              "smallest_margin": {"margin": mg, "source": src, "quantity": qn, "joint": joint}}
    (out / "fit.json").write_text(json.dumps(report, indent=2, default=_jsonable))
    print(f"\nwrote {out}/leg.toml (for exoleg simulate --leg) and {out}/fit.json")
    return 0


def _jsonable(o: Any) -> Any:
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, (np.floating, np.integer, np.bool_)):
        return o.item()
    return str(o)


def cmd_population(args: argparse.Namespace) -> int:
    import collections

    from exoleg.sizing.population import PERCENTILES, coverage, heatmap, write_csv

    t0 = time.perf_counter()
    rows = coverage(ages=args.ages, percentiles=args.percentiles or PERCENTILES,
                    stride_time=args.stride_time, simulate=not args.no_simulate)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    csv_path = write_csv(rows, out / "coverage.csv")
    png = heatmap(rows, out / "coverage.png")
    groups = list(dict.fromkeys(r.group for r in rows))
    table = []
    for g in groups:
        for sex in ("female", "male"):
            sel = [r for r in rows if r.group == g and r.sex == sex]
            if not sel:
                continue
            miss = collections.Counter(r.binding for r in sel if not r.fits)
            worst = min(sel, key=lambda r: r.margin)
            table.append([g, sex, f"{sum(r.fits for r in sel)}/{len(sel)}",
                          f"{sum(r.paper_rule_fits for r in sel)}/{len(sel)}",
                          "; ".join(f"{k} x{v}" for k, v in miss.items()) or "-",
                          f"{worst.margin:.2f} ({worst.margin_where})"])
    print(_table(table, ["group", "sex", "fit", "paper rule fits", "misses (binding limit)",
                         "smallest actuator margin"]))
    print("\nthe paper's design range (50th percentile):")
    for grp, sex, age in (("GMFCS IV", "female", 8.0), ("GMFCS I", "male", 12.0)):
        r = [x for x in rows if x.group == grp and x.sex == sex and x.age == age
             and x.percentile == 50.0]
        if r:
            x = r[0]
            print(f"  {grp} {sex} {age:g} y: {x.height * 100:.1f} cm -> "
                  f"{'fits' if x.fits else 'does not fit'} ({x.binding}, "
                  f"{x.by_m * 100:+.1f} cm); paper rule: {'fits' if x.paper_rule_fits else 'no'}")
    print(f"\nwrote {csv_path} and {png} ({time.perf_counter() - t0:.1f} s)")
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

    f = sub.add_parser("fit", help="fit the device to one child: dimensions, settings, verdict, "
                       "margins; writes the personalized leg file")
    f.add_argument("--age", type=float, required=True, help="years")
    f.add_argument("--sex", choices=["female", "male"], required=True)
    f.add_argument("--height", type=_positive, required=True, help="cm")
    f.add_argument("--mass", type=_positive, required=True, help="body mass, kg")
    f.add_argument("--gmfcs", type=int, choices=[0, 1, 2, 3, 4, 5], default=0,
                   help="GMFCS level; 0 = typically developing (WHO 2007 chart)")
    f.add_argument("--side", choices=["left", "right"], default="right")
    for name in ("thigh", "shank", "leg-length", "foot-length", "ankle-height"):
        f.add_argument(f"--{name}", type=_positive, help=f"measured {name}, cm")
    f.add_argument("--leg-length-method", choices=["linear", "drillis", "table1"],
                   default="linear")
    f.add_argument("--percentile", type=float, default=50.0, help="gait demand percentile")
    f.add_argument("--speed", default="Free",
                   choices=["VerySlow", "Slow", "Free", "Fast", "VeryFast"])
    f.add_argument("--stride-time", type=_positive, default=1.1, help="s per gait cycle")
    f.add_argument("--no-simulate", action="store_true", help="skip the simulated gait demand")
    f.add_argument("--name", default="child")
    f.add_argument("--out", type=Path, default=Path("exoleg-fit"))
    f.set_defaults(func=cmd_fit)

    pop = sub.add_parser("population", help="device coverage over ages 8-12, sex, GMFCS I-IV "
                         "and TD, height percentiles")
    pop.add_argument("--ages", type=_floats, default=[8.0, 9.0, 10.0, 11.0, 12.0])
    pop.add_argument("--percentiles", type=_floats)
    pop.add_argument("--stride-time", type=_positive, default=1.1)
    pop.add_argument("--no-simulate", action="store_true")
    pop.add_argument("--out", type=Path, default=Path("exoleg-population"))
    pop.set_defaults(func=cmd_population)
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


def run() -> int:
    """The ``exoleg`` console command: :func:`main`, then a quick exit. Freezing the
    heap first spares the interpreter's final collection (a few hundred ms with numba,
    MuJoCo and matplotlib loaded); exit handlers still run."""
    code = main()
    gc.freeze()
    return code


if __name__ == "__main__":
    raise SystemExit(run())
