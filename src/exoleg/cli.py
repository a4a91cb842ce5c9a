"""The ``exoleg`` command line: a thin layer over the library.

Exit status: 0 done; 1 a validation that failed or a run that could not finish (the
message says why); 2 a bad option or input (one line naming it and what is allowed);
130 interrupted (Ctrl-C). Never a traceback: an unexpected error is one line too, with
``EXOLEG_DEBUG=1`` to see the traceback. Outputs are written whole or not at all
(:class:`exoleg.io.OutputFolder`): an error or Ctrl-C leaves the previous output.

Tables and progress bars use rich, imported only when something is printed.
"""

from __future__ import annotations

import argparse
import gc
import json
import math
import os
import signal
import sys
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, NoReturn

from exoleg.entry import BODY_MASS, CHILD_ENTRY, CONTROLLERS, DEFAULT_BODY_MASS, LAWS, MEASURED

if TYPE_CHECKING:
    from rich.console import Console

#: Stride times a child can walk (as exoleg.reference.gait.STRIDE_TIME_RANGE, kept here
#: so that the parser does not import numpy); gait SD offsets: mean +- 3 SD.
STRIDE_TIME_RANGE = (0.4, 4.0)
SD_RANGE = (-3.0, 3.0)
#: simulate --walk options' defaults (refused without --walk when changed)
_WALK_DEFAULTS: dict[str, Any] = {"strides": 10, "body_mass": DEFAULT_BODY_MASS,
                                  "ankle_height": 5.0, "noise": 1.0, "seed": 0}


class _Parser(argparse.ArgumentParser):
    """argparse, but an error is one line (``exoleg: error: ...``) and exit status 2."""

    def error(self, message: str) -> NoReturn:
        self.exit(2, f"exoleg: error: {message}\n")


def _console() -> Console:
    from rich.console import Console

    # on a terminal rich fits its width; piped or redirected, wide lines are kept whole
    return Console(highlight=False, width=None if sys.stdout.isatty() else 200)


def _table(rows: list[list[str]], header: list[str], title: str | None = None) -> None:
    """Print a table (rich; plain columns when not on a terminal)."""
    from rich import box
    from rich.table import Table

    t = Table(*header, title=title, box=box.SIMPLE_HEAD, title_justify="left",
              header_style="bold", pad_edge=False)
    for r in rows:
        t.add_row(*r)
    _console().print(t)


def _say(text: str = "", flush: bool = False) -> None:
    print(text, flush=flush)


def _url(host: str, port: int, tls: object) -> str:
    return f"{'https' if tls else 'http'}://{f'[{host}]' if ':' in host else host}:{port}"


# --------------------------------------------------------------------------- option types
def _floats(text: str, n: int | None = None) -> list[float]:
    try:
        vals = [float(v) for v in text.replace(" ", "").split(",") if v != ""]
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected comma-separated numbers, got {text!r}") from None
    if not vals:
        raise argparse.ArgumentTypeError(f"expected comma-separated numbers, got {text!r}")
    if n is not None and len(vals) != n:
        raise argparse.ArgumentTypeError(f"expected {n} comma-separated numbers, got {text!r}")
    if not all(math.isfinite(v) for v in vals):
        raise argparse.ArgumentTypeError(f"numbers must be finite, got {text!r}")
    return vals


def _three(text: str) -> list[float]:
    return _floats(text, 3)


def _postures(text: str) -> list[list[float]]:
    out = [_floats(p, 3) for p in text.split(";") if p.strip()]
    if not out:
        raise argparse.ArgumentTypeError(f"expected postures 'h,k,a;h,k,a', got {text!r}")
    return out


def _number(text: str) -> float:
    return _floats(text, 1)[0]


def _positive(text: str) -> float:
    v = _number(text)
    if v <= 0:
        raise argparse.ArgumentTypeError(f"must be > 0, got {text}")
    return v


def _within(lo: float, hi: float, unit: str = "") -> Callable[[str], float]:
    def parse(text: str) -> float:
        v = _number(text)
        if not lo <= v <= hi:
            raise argparse.ArgumentTypeError(f"{text} is outside {lo:g}-{hi:g}{unit}")
        return v
    parse.__name__ = "number"
    return parse


_body_mass = _within(BODY_MASS[0], BODY_MASS[1], " " + BODY_MASS[2])


def _count(lo: int, hi: int) -> Callable[[str], int]:
    def parse(text: str) -> int:
        try:
            v = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected a whole number, got {text!r}") from None
        if not lo <= v <= hi:
            raise argparse.ArgumentTypeError(f"{v} is outside {lo}-{hi}")
        return v
    parse.__name__ = "count"
    return parse


def _percentile(text: str) -> float:
    v = _number(text)
    if not 0.0 < v < 100.0:
        raise argparse.ArgumentTypeError(
            f"a percentile is between 0 and 100 (exclusive), got {text}")
    return v


def _percentiles(text: str) -> list[float]:
    vals = _floats(text)
    bad = [v for v in vals if not 0.0 < v < 100.0]
    if bad:
        raise argparse.ArgumentTypeError(
            f"percentiles are between 0 and 100 (exclusive), got {bad[0]:g}")
    return vals


def _ages(text: str) -> list[float]:
    vals = _floats(text)
    bad = [v for v in vals if not 2.0 <= v <= 20.0]
    if bad:
        raise argparse.ArgumentTypeError(f"ages are 2-20 years (the growth charts), got {bad[0]:g}")
    return vals


class _Progress:
    """A rich progress bar on stderr, only when stderr is a terminal."""

    def __init__(self) -> None:
        self.bar: Any = None
        self.tasks: dict[str, Any] = {}
        if sys.stderr.isatty():
            from rich.console import Console
            from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

            self.bar = Progress(TextColumn("{task.description:<10}"), BarColumn(),
                                TextColumn("{task.percentage:>5.1f}%"), TimeElapsedColumn(),
                                console=Console(stderr=True), transient=True)
            self.bar.start()

    def __call__(self, stage: str, fraction: float) -> None:
        if self.bar is None:
            return
        if stage not in self.tasks:
            self.tasks[stage] = self.bar.add_task(stage, total=1.0)
        self.bar.update(self.tasks[stage], completed=fraction)

    def stop(self) -> None:
        if self.bar is not None:
            self.bar.stop()


# --------------------------------------------------------------------------- validate
def cmd_validate(args: argparse.Namespace) -> int:
    if args.gait_phase:
        from exoleg.validate.gait_phase import evaluate

        rows, rows_ok, runs = evaluate(strides=args.strides)
        _table([[r.child, f"x{r.noise:g}", str(r.strides),
                 "stopped by the safety layer" if r.fault else "ok"] for r in runs],
               ["child", "sensor noise", "strides", "walk"])
        _table(_detection_rows(rows), _DETECTION_HEADER,
               title="gait-phase detection (FSR) against the true contacts, all runs")
        if rows_ok and len(rows_ok) != len(rows) or any(r.fault for r in runs):
            _table(_detection_rows(rows_ok), _DETECTION_HEADER,
                   title="the same, runs the safety layer did not stop")
        _say("published, shank gyroscope: initial contact -25 ms, foot off < 75 ms, > 98 % "
             "detected (Catalfamo et al. 2010); children with CP: onset < 100 ms, > 99 % of "
             "phases (Behboodi et al. 2019)")
        return 1 if any(r.fault for r in runs) else 0
    from exoleg.validate.checks import missing_engines, run_all

    checks = run_all(quick=args.quick)
    check_rows = [[c.name, c.reference, f"{c.figure:.2e}",
             (f"[{c.lower:g}, {c.tolerance:g}]" if c.lower is not None
              else f"<= {c.tolerance:.0e}"),
             "pass" if c.passed else "FAIL", c.detail] for c in checks]
    _table(check_rows, ["check", "reference", "figure", "tolerance", "", "detail"])
    for m in missing_engines():
        _say(f"skipped: {m} is not installed (pip install exoleg[validate])")
    failed = [c for c in checks if not c.passed]
    _say(f"\n{len(checks) - len(failed)} passed, {len(failed)} failed")
    return 1 if failed else 0


# --------------------------------------------------------------------------- simulate
def _paper_scenario(args: argparse.Namespace) -> bool:
    """Whether these options run the paper's own scenario (section 6): only then are the
    paper's figures printed beside exoleg's."""
    return (args.reference == "paper" and args.leg is None and args.controller == "pd-gravity"
            and args.kp is None and args.kd is None and not args.saturate
            and args.duration == 12.0 and args.dt == 1e-3 and args.control_rate == 1000.0
            and args.q0 is None and args.postures is None and args.times is None)


def _read_leg(path: Path) -> tuple[Any, str]:
    """A leg file as a :class:`~exoleg.LegModel`, and a warning ('' if none) when it is a
    leg for a child the device does not fit (its ``[fit]`` record)."""
    import exoleg
    from exoleg.params.leg_file import read_leg_file

    links, g, name, meta = read_leg_file(path)
    leg = exoleg.LegModel(links, g=g, name=name, armature=meta.get("armature"))
    if meta.get("fits", True):
        return leg, ""
    return leg, (f"{path} is a leg for a child the device does not fit "
                 f"({meta.get('note') or 'see its [fit] record'}): the model's telescope "
                 "settings are clamped to the device's range")


def _check_combination(args: argparse.Namespace) -> None:
    """Options that mean nothing with the chosen reference are refused, not ignored."""
    from exoleg.errors import ParameterError

    gait_only = {"speed": args.speed, "stride_time": args.stride_time, "sd": args.sd}
    steps_only = {"postures": args.postures, "times": args.times}
    if args.reference == "gait":
        given = [k for k, v in steps_only.items() if v is not None]
    else:
        given = [k for k, v in gait_only.items() if v is not None]
    if given:
        opt = "--" + given[0].replace("_", "-")
        allowed = ("--reference steps, minjerk or paper" if args.reference == "gait"
                   else "--reference gait")
        raise ParameterError("exoleg simulate", opt,
                             f"does not apply to --reference {args.reference} (it goes with "
                             f"{allowed})")
    if (args.times is not None and args.postures is not None
            and len(args.times) != len(args.postures)):
        raise ParameterError("exoleg simulate", "--times",
                             f"{len(args.times)} times for {len(args.postures)} postures; give "
                             "one time per posture")


def _build(args: argparse.Namespace) -> dict[str, Any]:
    """Leg, controller, reference and run settings from the options (raises ExolegError)."""
    import numpy as np

    import exoleg
    from exoleg.control.controllers import law_named
    from exoleg.reference import MinJerk, Reference, SchwartzGait2008, Steps
    from exoleg.sim import scenario

    _check_combination(args)
    warnings: list[str] = []
    if args.leg:
        leg, warning = _read_leg(args.leg)
        warnings += [warning] if warning else []
    else:
        leg = exoleg.paper_leg("simplified")
    ctrl = law_named(args.controller, leg, args.kp, args.kd,
                     saturation=True if args.saturate else None)
    changes = None
    ref: Reference
    if args.reference in ("paper", "steps", "minjerk"):
        default = scenario.paper_reference()
        post: Any = np.radians(args.postures) if args.postures else default.postures
        times: Any = (np.array(args.times, dtype=float) if args.times else
                      default.times if args.postures is None else np.arange(len(post)) * 3.0)
        ref = (MinJerk if args.reference == "minjerk" else Steps)(times, post)
        if args.reference != "minjerk":
            changes = ref.times
    else:
        ref = SchwartzGait2008(stride_time=args.stride_time or 1.2, speed=args.speed or "Free",
                               sd=args.sd or 0.0)
    q0 = np.radians(args.q0) if args.q0 is not None else (
        np.zeros(3) if args.reference == "paper" else None)
    paper_leg = args.reference == "paper" and not args.leg
    detailed = exoleg.paper_leg("detailed") if paper_leg else None
    return {"leg": leg, "controller": ctrl, "reference": ref, "q0": q0, "detailed": detailed,
            "changes": changes if changes is not None else [0.0], "warnings": warnings}


def _summary_rows(figs: dict[str, Any], paper: bool) -> list[list[str]]:
    """Figure rows; the paper's values only when the run is the paper's scenario."""
    def ref(text: str) -> str:
        return text if paper else "-"

    rows = []
    if "detailed_vs_simplified_max_deg" in figs:
        rows.append(["detailed (2x torque) vs simplified, max deg",
                     f"{figs['detailed_vs_simplified_max_deg']:.2e}", ref("1e-13 (Fig. 13D)")])
    for k, v in figs.items():
        if k.startswith("exoleg_vs_"):
            rows.append([f"exoleg vs {k[10:-8]}, max deg", f"{v:.2e}", ref("1e-11 (Fig. 13E)")])
    errs = figs["tracking_error_at_segment_ends_deg"]
    rows.append(["tracking error at segment ends, max deg", f"{max(errs):.2e}",
                 ref("1e-6 (Fig. 13F)")])
    rows.append(["verification dq^T(Mdot-2C)dq, max |W|", f"{figs['verification_max_abs']:.1e}",
                 ref("1e-16 (Fig. 14)")])
    rows.append(["   relative to |dq^T Mdot dq|", f"{figs['verification_relative']:.1e}", "-"])
    rows.append(["V (eq 26) largest rise within a segment, J",
                 f"{figs['lyapunov_max_rise_within_segments_J']:.1e}",
                 "0 in continuous time (eq 30)"])
    rows.append(["sampled-loop margin h*lambda", f"{figs['sampled_stability_h_lambda']:.3f}",
                 "< 2 stable"])
    rows.append(["steps with saturated torque", str(figs["saturated_steps"]), "-"])
    return rows


def _ignore_sigint() -> None:
    """Worker processes leave Ctrl-C to the parent, which stops them and reports once."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)


def _prepare_worker() -> None:
    _ignore_sigint()
    from exoleg.sim.closed_loop import warm_up

    warm_up()
    import exoleg.plots.figures  # noqa: F401


def _save_figures(report: Any, folder: Path, formats: tuple[str, ...]) -> list[str]:
    from exoleg.plots.figures import save_figures

    paths = save_figures(report, folder, formats)
    gc.freeze()  # this worker's last task: let it exit without a final collection (see run)
    return [p.name for p in paths]


def _actuator_peaks(acts: Any, tau: Any, dq: Any, u_safe: Any, env: Any) -> list[dict[str, Any]]:
    """Per actuator, what a run asked of it against its limits (SI; speeds in deg/s)."""
    import numpy as np

    out = []
    for i, a in enumerate(acts):
        out.append({
            "joint": a.joint, "reflected_inertia_kg_m2": a.reflected_inertia,
            "peak_torque_Nm": float(np.abs(tau[:, i]).max()), "torque_limit_Nm": a.torque_limit,
            "rms_torque_Nm": float(np.sqrt(np.mean(tau[:, i] ** 2))),
            "continuous_torque_Nm": a.continuous_torque,
            "peak_speed_deg_s": float(np.degrees(np.abs(dq[:, i]).max())),
            "max_velocity_deg_s": float(np.degrees(a.max_velocity)),
            "peak_motor_speed_rpm": float(np.abs(dq[:, i]).max() * a.ratio * 30 / np.pi),
            "peak_power_W": float(np.abs(tau[:, i] * dq[:, i]).max()), "power_W": a.power,
            "ticks_at_envelope": int((np.abs(u_safe[:, i]) > env[:, i] + 1e-12).sum())})
    return out


def _settings(args: argparse.Namespace) -> dict[str, Any]:
    """The options a run was given, for its summary (paths and arrays as text)."""
    import numpy as np

    return {k: (str(v) if isinstance(v, (Path, np.ndarray)) else v)
            for k, v in vars(args).items() if k != "func"}


def _write_run(args: argparse.Namespace, result: Any, figure: Any, stem: str, t0: float,
               summary: dict[str, Any]) -> str:
    """A run's outputs, committed together: the time series (``--format``), its figure
    (PNG, and SVG with ``--svg``) and ``summary.json`` (the settings, ``summary``, the
    files, the wall time). Returns the line that says what was written."""
    from exoleg.io import OutputFolder

    with OutputFolder(args.out) as out:
        name = "timeseries.parquet" if args.format == "parquet" else "timeseries.csv"
        (result.to_parquet if args.format == "parquet" else result.to_csv)(out.stage(name))
        files = [name]
        for fmt in ("png", "svg") if args.svg else ("png",):
            figure(result, out.stage(f"{stem}.{fmt}"))
            files.append(f"{stem}.{fmt}")
        record = {"settings": _settings(args), **summary, "files": files,
                  "wall_time_s": time.perf_counter() - t0}
        out.stage("summary.json").write_text(json.dumps(record, indent=2, default=str))
        out.commit(last="summary.json")
    return (f"\nwrote {out.folder}/: " + ", ".join(["summary.json", *files])
            + f"  ({record['wall_time_s']:.1f} s)")


def _simulate_device(args: argparse.Namespace, cfg: dict[str, Any]) -> int:
    """``simulate --actuators``: the run through the device's actuators, encoders and
    safety layer (:func:`exoleg.sim.device_loop.simulate_device`), against Table 2."""
    import numpy as np

    from exoleg.errors import ParameterError
    from exoleg.plots.figures import device_figure
    from exoleg.sim.device_loop import simulate_device

    t0 = time.perf_counter()
    control_dt = 1.0 / args.control_rate
    substeps = int(round(control_dt / args.dt))
    if substeps < 1 or abs(substeps * args.dt - control_dt) > 1e-9 * control_dt:
        raise ParameterError("exoleg simulate", "--dt", f"{args.dt:g} s must divide the "
                             f"control period {control_dt:g} s with --actuators")
    if args.saturate:
        raise ParameterError("exoleg simulate", "--saturate", "does not apply with "
                             "--actuators (the safety layer and the drives limit the torque)")
    r = simulate_device(cfg["leg"], cfg["controller"], cfg["reference"], args.duration,
                        control_dt=control_dt, substeps=substeps, q0=cfg["q0"],
                        device=args.device)
    ideal = None
    if not args.no_engine:  # the same run with ideal torques, for the comparison
        from exoleg import simulate

        ideal = simulate(cfg["leg"], cfg["controller"], cfg["reference"], args.duration,
                         dt=control_dt, q0=cfg["q0"])
    acts = r.actuators
    peaks = _actuator_peaks(acts, r.tau, r.dq, r.u_safe, r.envelope)
    rows = []
    for i, (a, peak) in enumerate(zip(acts, peaks, strict=True)):
        peak["peak_command_Nm"] = float(np.abs(r.u_command[:, i]).max())
        rows.append([a.joint, f"{a.reflected_inertia:.3g}",
                     f"{peak['peak_command_Nm']:.1f} / {peak['peak_torque_Nm']:.1f} / "
                     f"{a.torque_limit:.0f}",
                     f"{peak['rms_torque_Nm']:.1f} / {a.continuous_torque:.0f}",
                     f"{peak['peak_speed_deg_s']:.0f} / {peak['max_velocity_deg_s']:.0f}",
                     f"{peak['peak_power_W']:.1f} / {a.power:.0f}",
                     str(peak["ticks_at_envelope"])])
    status = np.bitwise_or.reduce(r.status)
    figs = {
        "sampled_stability_h_lambda": r.stability_margin,
        "sampled_stability_without_actuators": None if ideal is None else ideal.stability_margin,
        "max_tracking_error_last_second_deg": float(np.degrees(np.abs(
            r.error[-int(round(1.0 / control_dt)):]).max())),
        "ideal_max_tracking_error_last_second_deg": None if ideal is None else float(
            np.degrees(np.abs(ideal.error[-int(round(1.0 / control_dt)):]).max())),
        "max_encoder_error_deg": float(np.degrees(np.abs(r.q_meas - r.q).max())),
        "safety_fault": r.fault,
        "safety_ticks_rate_limited": int(((r.status & 16) > 0).sum()),
        "safety_ticks_torque_clipped": int(((r.status & 8) > 0).sum()),
        "safety_ticks_soft_limit": int(((r.status & 4) > 0).sum()),
        "peaks": peaks,
    }
    wrote = _write_run(args, r, device_figure, "actuators", t0,
                       {"leg": cfg["leg"].name, "figures": figs, "notes": cfg["warnings"],
                        "actuator_sources": {a.joint: a.sources for a in acts}})
    _say(f"exoleg simulate --actuators: {args.reference} reference, {args.controller} "
         f"controller, {args.duration:g} s, control {args.control_rate:g} Hz, "
         f"{substeps} plant step(s) per tick, leg '{cfg['leg'].name}' with the paper's "
         "actuators (reflected inertia, friction, envelope, current loop), 20-bit encoders "
         "and the safety layer")
    _table(rows, ["joint", "armature kg m^2", "torque command / delivered / limit N m",
                  "RMS / continuous N m", "speed / Table 2 deg/s", "power / rated W",
                  "ticks at envelope"])
    fig_rows = [["sampled-loop margin h*lambda", f"{r.stability_margin:.3f}",
                 "-" if ideal is None else f"{ideal.stability_margin:.3f}"],
                ["max tracking error, last second, deg",
                 f"{figs['max_tracking_error_last_second_deg']:.2e}",
                 "-" if ideal is None
                 else f"{figs['ideal_max_tracking_error_last_second_deg']:.2e}"],
                ["encoder quantisation, max deg", f"{figs['max_encoder_error_deg']:.1e}", "0"],
                ["ticks torque-rate limited / clipped / at soft limit",
                 f"{figs['safety_ticks_rate_limited']} / {figs['safety_ticks_torque_clipped']} / "
                 f"{figs['safety_ticks_soft_limit']}", "-"],
                ["safety fault", r.fault or "none", "-"]]
    _table(fig_rows, ["figure", "with the actuators", "ideal torques"])
    if status & 2:
        _say(f"note: the safety layer stopped the run: {r.fault}; torque was off from then on")
    _say("note: motor, gear and drive figures marked catalogue* in the actuator files are "
         "to be verified against the datasheets (see summary.json, actuator_sources)")
    _say(wrote)
    return 0


def _detection_rows(rows: list[dict[str, Any]]) -> list[list[str]]:
    def ms(v: float) -> str:
        return "-" if v != v else f"{v:+.0f}"

    def pct(v: float) -> str:
        return "-" if v != v else f"{100 * v:.1f} %"

    return [[r["event"], str(r["true"]), ms(r["mean_error_ms"]), ms(r["worst_error_ms"]),
             pct(r["missed_rate"]), pct(r["false_rate"])] for r in rows]


_DETECTION_HEADER = ["event", "true events", "mean error ms", "worst error ms", "missed",
                     "false"]


def _simulate_walk(args: argparse.Namespace) -> int:
    """``simulate --walk``: a fitted child (or the paper's leg) walking on the treadmill
    with the whole device (:func:`exoleg.sim.walk.simulate_walk`)."""
    import dataclasses

    import numpy as np

    import exoleg
    from exoleg.errors import ParameterError
    from exoleg.plots.figures import walk_figure
    from exoleg.sim.metrics import detection_table
    from exoleg.sim.walk import simulate_walk

    t0 = time.perf_counter()
    for opt in ("postures", "times", "kp", "kd", "q0", "sd"):
        if getattr(args, opt) is not None:
            raise ParameterError("exoleg simulate", f"--{opt.replace('_', '-')}",
                                 "does not apply with --walk (the walking controller's gains "
                                 "are data/device/walking_control.toml)")
    for opt in ("saturate", "actuators", "beyond_rom", "animate"):
        if getattr(args, opt):
            raise ParameterError("exoleg simulate", f"--{opt.replace('_', '-')}",
                                 "does not apply with --walk")
    if args.reference != "paper" or args.controller != "pd-gravity":
        raise ParameterError("exoleg simulate", "--reference/--controller",
                             "do not apply with --walk (it follows normative gait at the "
                             "detected phase)")
    notes: list[str] = []
    if args.leg:
        leg, warning = _read_leg(args.leg)
        notes += [warning] if warning else []
    else:
        leg = exoleg.paper_leg("simplified")
    stride = args.stride_time or 1.1
    r = simulate_walk(leg, args.body_mass, strides=args.strides, speed=args.speed or "Free",
                      stride_time=stride, noise_scale=args.noise, seed=args.seed,
                      ankle_height=args.ankle_height / 100, device=args.device)
    rows = detection_table([r])
    walking = r.t >= r.walk_start + stride
    err = np.degrees(np.sqrt(np.mean((r.q - r.q_ref)[walking] ** 2, axis=0)))
    peaks = _actuator_peaks(r.actuators, r.tau, r.dq, r.u_safe, r.envelope)
    for p, e in zip(peaks, err, strict=True):
        p["rms_tracking_error_deg"] = float(e)
    fault = bool(np.any(r.safety_status & 2))
    if fault:
        k = int(np.argmax(r.safety_status & 2))
        notes.append(f"the safety layer stopped the walk at t = {r.t[k]:.3f} s; torque was off "
                     "from then on")
    figs = {"strides_commanded": args.strides, "body_mass_kg": args.body_mass,
            "pelvis_mass_kg": r.plant.body_mass, "belt_speed_m_s": r.plant.belt_speed,
            "safety_fault": fault, "peaks": peaks, "gait_phase_detection": rows,
            "max_contact_force_N": float(r.contact_force.sum(axis=1).max())}
    wrote = _write_run(args, r, walk_figure, "walk", t0,
                       {"leg": leg.name, "figures": figs, "notes": notes,
                        "actuators": [dataclasses.asdict(a) for a in r.actuators]})
    _say(f"exoleg simulate --walk: leg '{leg.name}', body {args.body_mass:g} kg (pelvis carries "
         f"{r.plant.body_mass:.1f} kg), {args.strides} strides of {stride:g} s on a belt at "
         f"{r.plant.belt_speed:.2f} m/s, sensor noise x{args.noise:g} (seed {args.seed})")
    _table([[p["joint"], f"{p['rms_tracking_error_deg']:.1f}",
             f"{p['peak_torque_Nm']:.1f} / {p['torque_limit_Nm']:.0f}",
             f"{p['rms_torque_Nm']:.1f} / {p['continuous_torque_Nm']:.0f}",
             f"{p['peak_speed_deg_s']:.0f} / {p['max_velocity_deg_s']:.0f}",
             f"{p['peak_power_W']:.1f}", str(p["ticks_at_envelope"])] for p in peaks],
           ["joint", "RMS tracking deg", "peak torque / limit N m", "RMS / continuous N m",
            "speed / Table 2 deg/s", "peak power W", "ticks at envelope"])
    _table(_detection_rows(rows), _DETECTION_HEADER,
           title="gait-phase detection against the simulator's true contacts")
    for n in notes:
        _say(f"note: {n}")
    _say(wrote)
    return 1 if fault else 0


def cmd_simulate(args: argparse.Namespace) -> int:
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor

    from exoleg.io import OutputFolder
    from exoleg.sim.scenario import run_scenario

    t0 = time.perf_counter()
    if args.walk:
        return _simulate_walk(args)
    if args.device is not None and not args.actuators:
        from exoleg.errors import ParameterError

        raise ParameterError("exoleg simulate", "--device", "goes with --walk or --actuators")
    for opt in ("strides", "body_mass", "noise", "seed", "ankle_height"):
        if getattr(args, opt) != _WALK_DEFAULTS[opt]:
            from exoleg.errors import ParameterError

            raise ParameterError("exoleg simulate", f"--{opt.replace('_', '-')}",
                                 "goes with --walk")
    cfg = _build(args)
    for w in cfg["warnings"]:
        _say(f"warning: {w}")
    if args.actuators:
        return _simulate_device(args, cfg)
    paper = _paper_scenario(args)
    with OutputFolder(args.out) as out:
        progress = _Progress()
        # A second process compiles the kernels the scenario needs besides the stepper and
        # imports matplotlib while this one compiles the stepper and simulates, then draws
        # the figures while this one writes the time series (two cores, half the wait). On
        # Linux it is forked, before MuJoCo is loaded, and so starts with this process's
        # imports (0.5-0.8 s sooner than a spawned one); elsewhere it is spawned.
        method = "fork" if sys.platform == "linux" else "spawn"
        try:
            with ProcessPoolExecutor(1, mp_context=multiprocessing.get_context(method),
                                     initializer=_ignore_sigint) as pool:
                prepared = pool.submit(_prepare_worker)
                report = run_scenario(
                    cfg["leg"], cfg["controller"], cfg["reference"], args.duration, dt=args.dt,
                    control_dt=1.0 / args.control_rate, q0=cfg["q0"], detailed=cfg["detailed"],
                    engine=None if args.no_engine else "mujoco", changes=cfg["changes"],
                    progress=progress, beyond_range_of_motion=args.beyond_rom)
                # figures() reads the diagnostics, computed on first access: before the
                # report is pickled for the worker (in a feeder thread), not during it
                figs = report.figures()
                formats = ("png", "svg") if args.svg else ("png",)
                drawn = pool.submit(_save_figures, report, out.staging, formats)
                name = "timeseries.parquet" if args.format == "parquet" else "timeseries.csv"
                (report.result.to_parquet if args.format == "parquet"
                 else report.result.to_csv)(out.stage(name))
                files = [name]
                if args.animate:
                    from exoleg.plots import animate

                    progress("animation", 0.0)
                    movie = animate(cfg["leg"], report.result.t, report.result.q,
                                    out.stage("gait.mp4"), q_ref=report.result.q_ref)
                    out.stage(movie.name)
                    progress("animation", 1.0)
                prepared.result()
                for fname in drawn.result():
                    out.stage(fname)
                    files.append(fname)
                if args.animate:
                    files.append(movie.name)
        finally:
            progress.stop()
        notes = [*cfg["warnings"], *report.notes]
        summary = {
            "settings": _settings(args),
            "paper_scenario": paper,
            "leg": cfg["leg"].name,
            "figures": figs,
            "notes": notes,
            "files": files,
            "wall_time_s": time.perf_counter() - t0,
        }
        out.stage("summary.json").write_text(json.dumps(summary, indent=2, default=str))
        out.commit(last="summary.json")

    _say(f"exoleg simulate: {args.reference} reference, {args.controller} controller, "
         f"{args.duration:g} s at dt = {args.dt:g} s, control {args.control_rate:g} Hz, "
         f"leg '{cfg['leg'].name}'" + ("" if paper else " (not the paper's scenario: its "
                                       "figures are not compared)"))
    _table(_summary_rows(figs, paper), ["figure", "exoleg", "paper"])
    prow = [[r["joint"], f"{r['torque_Nm']:.1f} / {r['torque_limit_Nm']:.0f}",
             f"{r['speed_deg_s']:.0f} / {r['speed_limit_deg_s']:.0f}",
             f"{r['power_W']:.1f} / {r['power_limit_W']:.0f}",
             "yes" if r["within_limits"] else "NO"] for r in figs["peaks"]]
    _table(prow, ["joint", "peak torque / limit N m", "speed / limit deg/s",
                  "power / limit W", "within Table 2"])
    for n in notes:
        _say(f"note: {n}")
    _say(f"\nwrote {out.folder}/: " + ", ".join(["summary.json", *files])
         + f"  ({summary['wall_time_s']:.1f} s)")
    return 0


# --------------------------------------------------------------------------- fit
def cmd_fit(args: argparse.Namespace) -> int:
    import warnings

    import numpy as np

    from exoleg.io import OutputFolder
    from exoleg.sizing import Child
    from exoleg.sizing.demand import DISPLAY
    from exoleg.sizing.report import fit_report

    measured = {k: (getattr(args, k) / 100 if getattr(args, k) is not None else None)
                for k in MEASURED}
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        child = Child(age=args.age, sex=args.sex, height=args.height / 100, mass=args.mass,
                      gmfcs=args.gmfcs, affected_side=args.side, name=args.name,
                      accept_unusual=args.accept_unusual, **measured)
    for w in caught:
        _say(f"warning: {w.message}")
    with OutputFolder(args.out) as out:
        rep = fit_report(child, args.leg_length_method, percentile=args.percentile,
                         speed=args.speed, stride_time=args.stride_time,
                         simulate=not args.no_simulate)
        fit, demand, over = rep.fit, rep.demand, rep.over
        d = fit.dimensions
        charts = child.charts
        chart_text = charts["height"] + (f", weight {charts['weight']}"
                                         if charts["weight"] != charts["height"] else "")
        _say(f"{child.name}: {child.age:g} y {child.sex}, {child.height * 100:.1f} cm, "
             f"{child.mass:.1f} kg, {'GMFCS ' + str(child.gmfcs) if child.gmfcs else 'TD'} "
             f"({chart_text} chart)")
        _table([[k, f"{getattr(d, k) * 100:.1f}", d.sources[k]] for k in
                ("thigh", "shank", "ankle_height", "foot_length", "leg_length")],
               ["dimension", "cm", "source"])
        _say(f"geometric fit: {'FITS' if fit.fits else 'DOES NOT FIT'}")
        _say(f"  upper telescope (hip-knee) {fit.upper * 100:.1f} cm (27-40), lower telescope "
             f"(knee-sole) {fit.lower * 100:.1f} cm (33-46), footplate 23.5 cm")
        for m in fit.misses:
            _say(f"  misses: {m.what}: child {m.child * 100:.1f} cm, allowed "
                 f"{m.allowed[0] * 100:.1f}-{m.allowed[1] * 100:.1f} cm, by {m.by * 100:+.2f} cm")
        pr = fit.paper_rule
        _say(f"  paper's Table 1 rule: leg length {pr['leg_length'] * 100:.1f} cm vs 60-86 cm -> "
             f"{'fits' if pr['fits'] else 'does not fit'}")
        rom = fit.range_of_motion
        _say("  normative gait range (mean +- 2 SD) vs device range of motion, deg: " + ", ".join(
            f"{j} {np.degrees(rom['gait_lower'][i]):.0f}.."
            f"{np.degrees(rom['gait_upper'][i]):.0f} in "
            f"{np.degrees(rom['device_lower'][i]):.0f}..{np.degrees(rom['device_upper'][i]):.0f}"
            for i, j in enumerate(("hip", "knee", "ankle"))))
        rows = []
        for r in demand.table():
            u, k = DISPLAY[r["quantity"]]
            rows.append([r["source"], f"{r['quantity']} ({u})"] + [
                f"{r[j] * k:.1f} ({r[j + '_margin']:.2f})" + ("" if r[j + "_margin"] >= 1 else " !")
                for j in ("hip", "knee", "ankle")])
        lim = demand.limits
        rows.append(["Table 2 limits", "torque / speed / power"] + [
            f"{lim[0, j]:.0f} / {np.degrees(lim[1, j]):.0f} / {lim[2, j]:.0f}" for j in range(3)])
        _table(rows, ["source", "quantity", "hip", "knee", "ankle"],
               title="actuator demand (margin = limit / demand; ! = over the limit)")
        mg, src, qn, joint = demand.smallest_margin()
        if over:
            _say(f"actuator demand: EXCEEDS Table 2 in {len(over)} case(s):")
            for e in over:
                _say(f"  {e}")
        else:
            _say(f"actuator demand: within Table 2 (smallest margin {mg:.2f}: {qn} at the "
                 f"{joint}, {src})")
        _say(f"\nverdict: {rep.verdict}")
        write_leg = fit.fits or args.write_leg
        out.stage("fit.json").write_text(json.dumps(rep.record(write_leg), indent=2))
        written = ["fit.json"]
        if write_leg:
            rep.save_leg(out.stage("leg.toml"))
            written.insert(0, "leg.toml")
        out.commit(last="fit.json")
    if "leg.toml" in written:
        _say(f"wrote {out.folder}/leg.toml (for exoleg simulate --leg) and {out.folder}/fit.json")
    else:
        _say(f"wrote {out.folder}/fit.json; no leg file: the device does not fit this child "
             "(--write-leg writes one anyway, marked as such)")
    return 0


def cmd_population(args: argparse.Namespace) -> int:
    import collections

    from exoleg.io import OutputFolder
    from exoleg.sizing.population import PERCENTILES, coverage, heatmap, write_csv

    t0 = time.perf_counter()
    rows = coverage(ages=args.ages, percentiles=args.percentiles or PERCENTILES,
                    stride_time=args.stride_time, simulate=not args.no_simulate)
    with OutputFolder(args.out) as out:
        write_csv(rows, out.stage("coverage.csv"))
        heatmap(rows, out.stage("coverage.png"))
        out.commit()
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
                          f"{sum(r.fits and r.within_table2 for r in sel)}/{len(sel)}",
                          f"{sum(r.paper_rule_fits for r in sel)}/{len(sel)}",
                          "; ".join(f"{k} x{v}" for k, v in miss.items()) or "-",
                          f"{worst.margin:.2f} ({worst.margin_where})"])
    _table(table, ["group", "sex", "fits (geometry)", "fits, demand within Table 2",
                   "paper rule fits", "misses (binding limit)", "smallest actuator margin"])
    over = collections.Counter(w for r in rows for w in r.exceeds_where.split(", ") if w)
    if over:
        _say("demands over Table 2 (children, by joint and quantity): "
             + ", ".join(f"{k} x{v}" for k, v in over.most_common()))
    _say("\nthe paper's design range (50th percentile):")
    for grp, sex, age in (("GMFCS IV", "female", 8.0), ("GMFCS I", "male", 12.0)):
        r = [x for x in rows if x.group == grp and x.sex == sex and x.age == age
             and x.percentile == 50.0]
        if r:
            x = r[0]
            _say(f"  {grp} {sex} {age:g} y: {x.height * 100:.1f} cm -> "
                 f"{'fits' if x.fits else 'does not fit'} ({x.binding}, "
                 f"{x.by_m * 100:+.1f} cm); paper rule: {'fits' if x.paper_rule_fits else 'no'}")
    _say(f"\nwrote {out.folder}/coverage.csv and coverage.png ({time.perf_counter() - t0:.1f} s)")
    return 0


# --------------------------------------------------------------------------- export
def cmd_export(args: argparse.Namespace) -> int:
    import exoleg
    from exoleg.export import writers

    leg = exoleg.load_leg(args.leg) if args.leg else exoleg.paper_leg(args.variant)
    fmt = args.format or ("mjcf" if args.out.suffix == ".xml" else "urdf")
    write = writers.write_mjcf if fmt == "mjcf" else writers.write_urdf
    path = write(leg, args.out, mode=args.mode, frame=args.frame)
    _say(f"wrote {path} ({fmt.upper()}, {args.mode}, {args.frame}, leg '{leg.name}')")
    return 0


# --------------------------------------------------------------------------- run, log


def _bus_options(command: str, backend: str, **given: Any) -> None:
    """Refuses an option of the bus backends (``given``: name -> value, None when not
    given) on the ``sim`` backend."""
    from exoleg.errors import ParameterError

    for name, value in given.items():
        if backend == "sim" and value is not None:
            raise ParameterError(command, f"--{name.replace('_', '-')}",
                                 "goes with --backend canopen or ethercat")


def cmd_run(args: argparse.Namespace) -> int:
    from exoleg.runtime.session import check_options, run, summarize

    _bus_options("exoleg run", args.backend, interface=args.interface,
                 bus_timeout=args.bus_timeout)
    bus_timeout = None if args.bus_timeout is None else args.bus_timeout * 1e-3
    check_options(args.backend, args.interface, args.arm, args.walk_after, bus_timeout,
                  controller=args.controller, link=True if args.hmi else None)
    leg = None
    if args.leg:
        leg, warning = _read_leg(args.leg)
        if warning:
            _say(f"warning: {warning}")
    link = web = None
    if args.hmi:
        import secrets

        from exoleg.hmi.server import bind_check, start_process
        from exoleg.io import _writable_folder
        from exoleg.runtime.link import LoopLink

        warning = bind_check(args.hmi_host, args.tls_cert, args.tls_key)
        link, token = LoopLink.new(), secrets.token_urlsafe(16)
        web = start_process(link, _writable_folder(args.out), token, args.hmi_host,
                            args.hmi_port, args.tls_cert, args.tls_key, args.backend,
                            str(args.leg) if args.leg else None)
        if warning:
            _say(warning)
        _say(f"operator interface: {_url(args.hmi_host, args.hmi_port, args.tls_cert)}"
             f"/#token={token}\ntoken (for every control action): {token}", flush=True)
    try:
        res, path = run(args.backend, args.duration, args.out, period=1.0 / args.rate,
                        arm=args.arm, walk_after=args.walk_after, leg=leg,
                        body_mass=args.body_mass, seed=args.seed,
                        realtime=not args.no_realtime, interface=args.interface,
                        channel=args.channel, link=link, bus_timeout=bus_timeout,
                        controller=args.controller)
    finally:
        if web is not None:
            web.terminate()
            web.join(timeout=5)
    s = summarize(path)
    t = res.timing
    _say(f"exoleg run --backend {args.backend} --controller {args.controller}: {res.ticks} "
         f"ticks at {args.rate:g} Hz, ended "
         f"by {res.stopped_by}" + (f" ({', '.join(res.realtime)})" if res.realtime else ""))
    _table([[f"{t.get('p50_us', 0):.1f}", f"{t.get('p99_us', 0):.1f}",
             f"{t.get('p999_us', 0):.1f}", f"{t.get('max_us', 0):.1f}",
             str(t.get("missed", 0))]],
           ["late p50 us", "p99 us", "p99.9 us", "max us", "deadlines missed (> 1 period)"])
    from exoleg.control.contract import Mode, name_of

    _say("ticks per mode: " + ", ".join(f"{name_of(Mode, m)} {n}"
                                        for m, n in s["ticks_per_mode"].items())
         + f"; initial contacts {s['initial_contacts']}"
         + (f"; safety fault at {s['first_fault_s']:.3f} s" if s["first_fault_s"] else ""))
    from exoleg.runtime.log import MAX_LOSS_TICKS

    _say(f"\nwrote {path} (crash-safe: at most {MAX_LOSS_TICKS} ticks lost if killed) and "
         f"{Path(args.out) / 'run.json'}")
    stopped = res.stopped_by
    return 0 if stopped == "duration" else (130 if stopped.startswith("signal") else 1)


def cmd_hmi(args: argparse.Namespace) -> int:
    from exoleg.hmi.server import HMI, bind_check, listen, serve
    from exoleg.io import _writable_folder
    from exoleg.runtime.session import SIMULATED_BUS

    _bus_options("exoleg hmi", args.backend, interface=args.interface)
    warning = bind_check(args.host, args.tls_cert, args.tls_key)
    sock = listen(args.host, args.port)  # a port in use is said now, in one line
    hmi = HMI(_writable_folder(args.sessions), backend=args.backend,
              interface=args.interface or SIMULATED_BUS.get(args.backend))
    if warning:
        _say(warning)
    _say(f"operator interface: {_url(args.host, args.port, args.tls_cert)}/#token="
         f"{hmi.api.token}\ntoken (for every control action): {hmi.api.token}\n"
         f"sessions are recorded in {hmi.root}; Ctrl-C stops the interface (a running "
         "session ends, torque off)", flush=True)
    stopped = serve(hmi, args.host, args.port, args.tls_cert, args.tls_key, sock=sock)
    _say(f"operator interface stopped ({stopped or 'server ended'})")
    return 130 if stopped else 0  # stopped by a signal, as exoleg run


def cmd_log_summary(args: argparse.Namespace) -> int:
    from exoleg.io import OutputFolder
    from exoleg.runtime.session import summarize, to_table

    s = summarize(args.log)
    _table([[k, str(v)] for k, v in s.items()], ["", "value"],
           title=f"session log {args.log}")
    if args.csv or args.parquet:
        from exoleg.io import write_csv_table, write_parquet_table

        target = Path(args.csv or args.parquet)
        with OutputFolder(target.parent if str(target.parent) else ".") as out:
            (write_csv_table if args.csv else write_parquet_table)(
                to_table(args.log), out.stage(target.name))
            out.commit()
        _say(f"wrote {target}")
    return 0


# --------------------------------------------------------------------------- parser
def build_parser() -> argparse.ArgumentParser:
    ap = _Parser(prog="exoleg", description="Pediatric single-leg exoskeleton: model, control, "
                 "simulation (Sarajchi & Sirlantzis, Sensors 2023).")
    sub = ap.add_subparsers(dest="command", required=True, parser_class=_Parser)
    v = sub.add_parser("validate", help="check the model against the paper, Pinocchio, MuJoCo")
    v.add_argument("--quick", action="store_true", help="fewer random legs and states")
    v.add_argument("--gait-phase", action="store_true",
                   help="the gait-phase detector against the true contacts: children x noise")
    v.add_argument("--strides", type=_count(1, 1000), default=20, metavar="N",
                   help="with --gait-phase: strides per walk, 1-1000 (default 20)")
    v.set_defaults(func=cmd_validate)

    s = sub.add_parser("simulate", help="closed-loop simulation; default: the paper's scenario")
    s.add_argument("--reference", choices=["paper", "steps", "minjerk", "gait"], default="paper",
                   help="paper: its 3 s step schedule with normative stance/swing postures")
    s.add_argument("--postures", type=_postures,
                   help="steps/minjerk postures, deg: 'h,k,a;h,k,a;...' (knee flexion < 0)")
    s.add_argument("--times", type=_floats, help="steps/minjerk times, s: '0,3,6'")
    s.add_argument("--speed", choices=["VerySlow", "Slow", "Free", "Fast", "VeryFast"],
                   help="gait: Schwartz 2008 speed group (default Free)")
    s.add_argument("--stride-time", type=_within(*STRIDE_TIME_RANGE, " s"),
                   help="gait: s per cycle, 0.4-4 (default 1.2)")
    s.add_argument("--sd", type=_within(*SD_RANGE, " SD"), help="gait: mean + sd * SD, -3..3")
    s.add_argument("--controller", choices=LAWS,
                   default="pd-gravity")
    s.add_argument("--kp", type=_three, help="gains 'hip,knee,ankle' (default: paper's)")
    s.add_argument("--kd", type=_three, help="gains 'hip,knee,ankle' (default: paper's)")
    s.add_argument("--saturate", action="store_true", help="clip torques at Table 2's limits")
    s.add_argument("--duration", type=_positive, default=12.0, help="s (default 12)")
    s.add_argument("--dt", type=_within(1e-6, 1e-2, " s"), default=1e-3,
                   help="RK4 step, s, 1e-6 to 1e-2 (default 1e-3)")
    s.add_argument("--control-rate", type=_within(1.0, 1e6, " Hz"), default=1000.0,
                   help="Hz, 1 to 1e6 (default 1000)")
    s.add_argument("--q0", type=_three, help="initial posture, deg 'h,k,a'")
    s.add_argument("--beyond-rom", action="store_true",
                   help="simulate a start or reference outside the device's range of motion "
                        "(the summary says so)")
    s.add_argument("--leg", type=Path, help="leg parameter file (TOML); default: paper Table 5")
    s.add_argument("--out", type=Path, default=Path("exoleg-out"), help="output folder")
    s.add_argument("--format", choices=["csv", "parquet"], default="csv")
    s.add_argument("--svg", action="store_true", help="also write SVG figures")
    s.add_argument("--animate", action="store_true", help="write a gait animation (MP4/GIF)")
    s.add_argument("--no-engine", action="store_true",
                   help="skip the MuJoCo comparison (with --actuators: the ideal-torque run)")
    s.add_argument("--actuators", action="store_true",
                   help="run through the paper's actuators (reflected inertia, friction, "
                        "torque-speed envelope, current loop), 20-bit encoders and the safety "
                        "layer, and show what Table 2 allows")
    s.add_argument("--walk", action="store_true",
                   help="walk on a treadmill with the whole device: foot contacts, FSR and IMU, "
                        "gait-phase detection, the control hierarchy, safety layer, actuators")
    s.add_argument("--strides", type=_count(1, 10000), default=_WALK_DEFAULTS["strides"],
                   metavar="N", help="walk: strides, 1-10000 (default 10)")
    s.add_argument("--body-mass", type=_body_mass,
                   default=_WALK_DEFAULTS["body_mass"], help="walk: the child's mass, kg")
    s.add_argument("--ankle-height", type=_within(1.0, 15.0, " cm"),
                   default=_WALK_DEFAULTS["ankle_height"], help="walk: ankle above the sole, cm")
    s.add_argument("--noise", type=_within(0.0, 100.0), default=_WALK_DEFAULTS["noise"],
                   help="walk: sensor noise, times the datasheets' (0: ideal)")
    s.add_argument("--seed", type=_count(0, 2**31 - 1), default=_WALK_DEFAULTS["seed"],
                   help="walk: noise seed")
    s.add_argument("--device", type=Path, help="with --walk or --actuators: a folder of device "
                   "files (actuators/*.toml, sensors.toml, gait_phase.toml, "
                   "walking_control.toml, safety.toml, walking.toml) replacing the shipped ones")
    s.set_defaults(func=cmd_simulate)

    f = sub.add_parser("fit", help="fit the device to one child: dimensions, settings, verdict, "
                       "margins; writes the personalized leg file")
    entry = {k: _within(lo, hi, " " + unit) for k, (lo, hi, unit) in CHILD_ENTRY.items()}
    f.add_argument("--age", type=entry["age"], required=True,
                   help="years (2-20; the device targets 8-12)")
    f.add_argument("--sex", choices=["female", "male"], required=True)
    f.add_argument("--height", type=entry["height"], required=True, help="cm")
    f.add_argument("--mass", type=entry["mass"], required=True, help="body mass, kg")
    f.add_argument("--gmfcs", type=int, choices=[0, 1, 2, 3, 4, 5], default=0,
                   help="GMFCS level; 0 = typically developing (WHO 2007 / CDC 2000 charts)")
    f.add_argument("--side", choices=["left", "right"], default="right")
    for name in MEASURED:
        f.add_argument(f"--{name.replace('_', '-')}", type=entry["measured"],
                       help=f"measured {name.replace('_', ' ')}, cm")
    f.add_argument("--accept-unusual", action="store_true",
                   help="accept measured dimensions outside what is plausible for the height")
    f.add_argument("--leg-length-method", choices=["linear", "drillis", "table1"],
                   default="linear")
    f.add_argument("--percentile", type=_percentile, default=50.0, help="gait demand percentile")
    f.add_argument("--speed", default="Free",
                   choices=["VerySlow", "Slow", "Free", "Fast", "VeryFast"])
    f.add_argument("--stride-time", type=_within(*STRIDE_TIME_RANGE, " s"), default=1.1,
                   help="s per gait cycle, 0.4-4")
    f.add_argument("--no-simulate", action="store_true", help="skip the simulated gait demand")
    f.add_argument("--write-leg", action="store_true",
                   help="write leg.toml even when the device does not fit (marked as such)")
    f.add_argument("--name", default="child")
    f.add_argument("--out", type=Path, default=Path("exoleg-fit"))
    f.set_defaults(func=cmd_fit)

    pop = sub.add_parser("population", help="device coverage over ages 8-12, sex, GMFCS I-IV "
                         "and TD, height percentiles")
    pop.add_argument("--ages", type=_ages, default=[8.0, 9.0, 10.0, 11.0, 12.0])
    pop.add_argument("--percentiles", type=_percentiles)
    pop.add_argument("--stride-time", type=_within(*STRIDE_TIME_RANGE, " s"), default=1.1)
    pop.add_argument("--no-simulate", action="store_true")
    pop.add_argument("--out", type=Path, default=Path("exoleg-population"))
    pop.set_defaults(func=cmd_population)

    r = sub.add_parser("run", help="drive the device (or a simulated one) at a fixed rate: "
                       "sensors -> control hierarchy -> safety layer -> drives, logged")
    r.add_argument("--backend", choices=["sim", "canopen", "ethercat"], default="sim",
                   help="sim: the simulated device in real time; canopen: CiA 402 drives and "
                        "the foot board over CAN; ethercat: the same over EtherCAT (pysoem)")
    r.add_argument("--interface", help="canopen: python-can interface, 'virtual' (default: "
                   "hardware in the loop with simulated nodes) or e.g. 'socketcan'; "
                   "ethercat: network interface (e.g. eth0), or 'fake' (default: simulated "
                   "slaves at the process-data level)")
    r.add_argument("--channel", default="exoleg", help="canopen: the bus channel (e.g. can0)")
    r.add_argument("--bus-timeout", type=_within(0.1, 50.0, " ms"),
                   help="canopen/ethercat: how long the master waits for every node's answer "
                        "before it is a fault, ms (default 5; 20 on simulated nodes, threads "
                        "of this computer)")
    r.add_argument("--controller", choices=CONTROLLERS, default="walk",
                   help="walk: the walking hierarchy (default); pd-gravity, pd, "
                        "computed-torque: the paper's law following its scenario (stance "
                        "and swing postures every 3 s from the walk command; held at rest "
                        "while standing)")
    r.add_argument("--duration", type=_within(0.01, 86400.0, " s"), required=True, help="s")
    r.add_argument("--rate", type=_within(10.0, 10000.0, " Hz"), default=1000.0,
                   help="control rate, Hz (default 1000)")
    r.add_argument("--arm", action="store_true",
                   help="sim: the operator's arming, given at start (no motion without it)")
    r.add_argument("--walk-after", type=_within(0.0, 86400.0, " s"),
                   help="sim: the operator's walk command this many seconds in (needs --arm)")
    r.add_argument("--leg", type=Path, help="leg file (from exoleg fit); default the paper's")
    r.add_argument("--body-mass", type=_body_mass, default=DEFAULT_BODY_MASS,
                   help="the simulated child's mass, kg")
    r.add_argument("--seed", type=_count(0, 2**31 - 1), default=0, help="sim: sensor noise")
    r.add_argument("--hmi", action="store_true",
                   help="serve the operator interface (and its control API) for this session")
    _web_options(r, "--hmi-host", "--hmi-port")
    r.add_argument("--no-realtime", action="store_true",
                   help="do not ask for SCHED_FIFO (nor an isolated CPU, nor the bus threads' "
                        "priority)")
    r.add_argument("--out", type=Path, default=Path("exoleg-session"))
    r.set_defaults(func=cmd_run)

    h = sub.add_parser("hmi", help="the operator interface: fit a child, run and watch "
                       "sessions, review recorded ones (a web page on this machine)")
    h.add_argument("--backend", choices=["sim", "canopen", "ethercat"], default="sim",
                   help="what the sessions drive (default: the simulated device)")
    h.add_argument("--interface", help="canopen/ethercat: as for exoleg run (default: the "
                   "simulated nodes)")
    _web_options(h, "--host", "--port")
    h.add_argument("--sessions", type=Path, default=Path("exoleg-sessions"),
                   help="folder of recorded sessions and fitted children")
    h.set_defaults(func=cmd_hmi)

    lg = sub.add_parser("log", help="read a session log")
    lsub = lg.add_subparsers(dest="log_command", required=True, parser_class=_Parser)
    ls = lsub.add_parser("summary", help="what a session log holds (also a cut one)")
    ls.add_argument("log", type=Path, help="session.log, or the folder of exoleg run --out")
    ls.add_argument("--csv", type=Path, help="also write the series as CSV")
    ls.add_argument("--parquet", type=Path, help="also write the series as Parquet")
    ls.set_defaults(func=cmd_log_summary)

    e = sub.add_parser("export", help="write the leg as URDF or MJCF (limits, actuators, "
                       "geometry)")
    e.add_argument("--leg", type=Path, help="leg parameter file (default: the paper's leg)")
    e.add_argument("--variant", choices=["simplified", "detailed"], default="detailed",
                   help="the paper's leg when no --leg (default detailed)")
    e.add_argument("--format", choices=["urdf", "mjcf"],
                   help="default: from the suffix (.xml -> mjcf, else urdf)")
    e.add_argument("--mode", choices=["lumped", "welded"], default="lumped")
    e.add_argument("--frame", choices=["y-up", "z-up"], default="y-up",
                   help="y-up: exoleg's frame; z-up: for ROS tools (REP 103)")
    e.add_argument("--out", type=Path, required=True, help="file to write")
    e.set_defaults(func=cmd_export)
    return ap


def _web_options(p: argparse.ArgumentParser, host: str, port: str) -> None:
    p.add_argument(host, default="127.0.0.1", help="address to listen on (default: this "
                   "machine only; another address needs TLS or prints a warning)")
    p.add_argument(port, type=_count(1024, 65535), default=8780)
    p.add_argument("--tls-cert", help="TLS certificate (PEM) to serve https")
    p.add_argument("--tls-key", help="the certificate's private key (PEM)")


def _negative_values(argv: Sequence[str]) -> list[str]:
    """``--q0 -10,-40,5`` as ``--q0=-10,-40,5``: argparse takes a value that starts with
    '-' for an option unless it is a single plain number, and exoleg's angles are often
    negative (knee flexion)."""
    out: list[str] = []
    for a in argv:
        if (out and out[-1].startswith("--") and "=" not in out[-1] and len(a) > 1
                and a[0] == "-" and (a[1].isdigit() or a[1] == ".")):
            out[-1] = f"{out[-1]}={a}"
        else:
            out.append(a)
    return out


def main(argv: Sequence[str] | None = None) -> int:
    ap = build_parser()
    args = ap.parse_args(_negative_values(sys.argv[1:] if argv is None else argv))
    from exoleg.errors import ExolegError

    try:
        return int(args.func(args))
    except ExolegError as e:
        kind = "error" if isinstance(e, ValueError) else "failed"
        print(f"exoleg: {kind}: {e}", file=sys.stderr)
        return 2 if isinstance(e, ValueError) else 1
    except KeyboardInterrupt:
        print("exoleg: interrupted; nothing was written (any previous output is unchanged)",
              file=sys.stderr)
        return 130
    except BrokenPipeError:
        # the reader (e.g. `| head`) stopped reading: not an error of ours
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        return 0
    except ImportError as e:
        print(f"exoleg: error: {e}", file=sys.stderr)
        return 2
    except MemoryError:
        print("exoleg: failed: out of memory (shorten --duration or raise --dt)", file=sys.stderr)
        return 1
    except OSError as e:
        where = f" ({e.filename})" if getattr(e, "filename", None) else ""
        print(f"exoleg: failed: {e.strerror or e}{where}", file=sys.stderr)
        return 1
    except Exception as e:  # a bug: one line, the traceback on request
        if os.environ.get("EXOLEG_DEBUG"):
            raise
        print(f"exoleg: internal error: {type(e).__name__}: {e} (EXOLEG_DEBUG=1 shows the "
              "traceback; please report it)", file=sys.stderr)
        return 1


def run() -> int:
    """The ``exoleg`` console command: :func:`main`, then a quick exit. Freezing the
    heap first spares the interpreter's final collection (a few hundred ms with numba,
    MuJoCo and matplotlib loaded); exit handlers still run."""
    code = main()
    gc.freeze()
    try:
        sys.stdout.flush()
    except BrokenPipeError:
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
    return code


if __name__ == "__main__":
    raise SystemExit(run())
