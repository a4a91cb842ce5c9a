"""``exoleg simulate``: the paper's closed-loop scenario (the default), ``--actuators``
through the device (:mod:`exoleg.cli.simulate_device`), ``--walk`` on the treadmill
(:mod:`exoleg.cli.simulate_walk`). Which options go with which variant is declared once
(:data:`APPLIES`) and checked in one place."""

from __future__ import annotations

import argparse
import gc
import json
import signal
import sys
import time
from pathlib import Path
from typing import Any

from exoleg.cli._common import (
    SD_RANGE,
    STRIDE_TIME_RANGE,
    _body_mass,
    _count,
    _floats,
    _positive,
    _postures,
    _Progress,
    _read_leg,
    _say,
    _table,
    _three,
    _within,
)
from exoleg.cli._runs import settings
from exoleg.entry import DEFAULT_BODY_MASS, LAWS, SUPPORT_MODES

#: simulate --walk options' defaults
_WALK_DEFAULTS: dict[str, Any] = {"strides": 10, "body_mass": DEFAULT_BODY_MASS,
                                  "ankle_height": 5.0, "noise": 1.0, "seed": 0}
#: The three variants of ``exoleg simulate``: the paper's scenario (the default), through
#: the actuators (``--actuators``), walking on the treadmill (``--walk``); argparse keeps
#: the last two apart.
VARIANTS = ("scenario", "actuators", "walk")
_PAPER, _DEVICE = ("scenario", "actuators"), ("walk", "actuators")
#: Which variants each option goes with (an option not listed goes with all of them),
#: and why not, where that helps: one declaration, checked by :func:`check_variant`.
APPLIES: dict[str, tuple[tuple[str, ...], str]] = {
    "reference": (_PAPER, "it follows normative gait at the detected phase"),
    **{o: (_PAPER, "the walking controller's gains are data/device/walking_control.toml")
       for o in ("kp", "kd")},
    **{o: (_PAPER, "") for o in ("postures", "times", "sd", "q0", "beyond_rom", "no_engine")},
    **{o: (_PAPER, "its length is --strides") for o in ("duration",)},
    **{o: (_PAPER, "it runs at the device's 1 kHz") for o in ("dt", "control_rate")},
    "saturate": (("scenario",), "the safety layer and the drives limit the torque"),
    "animate": (("scenario",), ""),
    **{o: (("walk",), "") for o in _WALK_DEFAULTS},
    "device": (_DEVICE, ""),
    "hip_motor": (_DEVICE, ""),
    "child": (("walk",), ""),
    "sensor_fault": (("walk",), ""),
    "expected_stride": (("walk",), ""),
}
_FLAG = {"scenario": "the paper's scenario (neither --actuators nor --walk)",
         "actuators": "--actuators", "walk": "--walk"}


def _sensor_fault(text: str) -> Any:
    """``--sensor-fault``'s SPEC (:meth:`exoleg.device.faults.SensorFault.parse`)."""
    from exoleg.device.faults import SensorFault
    from exoleg.errors import ParameterError

    try:
        return SensorFault.parse(text)
    except ParameterError as e:
        raise argparse.ArgumentTypeError(f"{text!r}: {e.problem}") from None


def check_variant(args: argparse.Namespace) -> str:
    """The variant the options ask for; an option set away from its default that does
    not go with it is refused (ParameterError naming it and what it goes with)."""
    from exoleg.errors import ParameterError

    v = "walk" if args.walk else "actuators" if args.actuators else "scenario"
    names = SUPPORT_MODES if v == "walk" else LAWS
    if args.controller is None:  # each variant's own default
        args.controller = names[0]
    elif args.controller not in names:
        raise ParameterError("exoleg simulate", "--controller",
                             f"{args.controller!r} does not go with {_FLAG[v]} (allowed: "
                             + ", ".join(names) + ")")
    for dest, (goes, why) in APPLIES.items():
        if v not in goes and getattr(args, dest) != args.variant_defaults[dest]:
            opt = "--" + dest.replace("_", "-")
            if v == "scenario":
                raise ParameterError("exoleg simulate", opt,
                                     "goes with " + " or ".join(_FLAG[g] for g in goes))
            raise ParameterError("exoleg simulate", opt, f"does not apply with {_FLAG[v]}"
                                 + (f" ({why})" if why else ""))
    return v


def cmd_simulate(args: argparse.Namespace) -> int:
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor

    from exoleg.io import OutputFolder
    from exoleg.sim.scenario import run_scenario

    t0 = time.perf_counter()
    variant = check_variant(args)
    if variant == "walk":
        from exoleg.cli.simulate_walk import _simulate_walk

        return _simulate_walk(args)
    cfg = _build(args)
    for w in cfg["warnings"]:
        _say(f"warning: {w}")
    if variant == "actuators":
        from exoleg.cli.simulate_device import _simulate_device

        return _simulate_device(args, cfg)
    paper = _paper_scenario(args)
    with OutputFolder(args.out, owner="exoleg simulate") as out:
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
                engine, skipped = None, None
                if not args.no_engine:
                    from exoleg.validate.engines import scenario_engine

                    engine, skipped = scenario_engine(cfg["leg"], args.dt)
                report = run_scenario(
                    cfg["leg"], cfg["controller"], cfg["reference"], args.duration, dt=args.dt,
                    control_dt=1.0 / args.control_rate, q0=cfg["q0"], detailed=cfg["detailed"],
                    engine=engine, changes=cfg["changes"],
                    progress=progress, beyond_range_of_motion=args.beyond_rom)
                if skipped:
                    report.notes.append(skipped)
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
            "settings": settings(args),
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


# --------------------------------------------------------------------------- simulate
def _paper_scenario(args: argparse.Namespace) -> bool:
    """Whether these options run the paper's own scenario (section 6): only then are the
    paper's figures printed beside exoleg's."""
    return (args.reference == "paper" and args.leg is None and args.controller == "pd-gravity"
            and args.kp is None and args.kd is None and not args.saturate
            and args.duration == 12.0 and args.dt == 1e-3 and args.control_rate == 1000.0
            and args.q0 is None and args.postures is None and args.times is None)


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
    """Worker processes leave Ctrl-C to the parent, which stops them and reports once;
    and end with it, however it ends (a SIGKILL included): no orphan works on."""
    import os

    from exoleg._parent import when_parent_ends

    signal.signal(signal.SIGINT, signal.SIG_IGN)
    when_parent_ends(lambda: os._exit(1))


def _prepare_worker() -> None:
    # (the worker's initializer, _ignore_sigint, has set its signals and parent watch)
    from exoleg.sim.closed_loop import warm_up

    warm_up()
    import exoleg.plots.figures  # noqa: F401


def _save_figures(report: Any, folder: Path, formats: tuple[str, ...]) -> list[str]:
    from exoleg.plots.figures import save_figures

    paths = save_figures(report, folder, formats)
    gc.freeze()  # this worker's last task: let it exit without a final collection (see run)
    return [p.name for p in paths]


def add_parser(sub: Any) -> None:
    """Add ``exoleg simulate`` to the subcommands ``sub``."""
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
    s.add_argument("--controller", choices=(*LAWS, *SUPPORT_MODES),
                   help="the paper's scenario and --actuators: the law, " + ", ".join(LAWS)
                        + " (default pd-gravity); --walk: the walking controller's support "
                          "mode, " + ", ".join(SUPPORT_MODES) + " (default impedance)")
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
    variant = s.add_mutually_exclusive_group()
    variant.add_argument("--actuators", action="store_true",
                   help="run through the paper's actuators (reflected inertia, friction, "
                        "torque-speed envelope, current loop), 20-bit encoders and the safety "
                        "layer, and show what Table 2 allows")
    variant.add_argument("--walk", action="store_true",
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
    s.add_argument("--device", type=Path, metavar="DIR",
                   help="with --walk or --actuators: a folder of device "
                   "files (actuators/*.toml, sensors.toml, gait_phase.toml, "
                   "walking_control.toml, safety.toml, walking.toml) replacing the shipped ones")
    from exoleg.entry import HIP_VARIANTS

    s.add_argument("--hip-motor", choices=HIP_VARIANTS, help="with --walk or --actuators: the "
                   "hip's motor variant (data/device/hip-variants; the shipped hip is "
                   "ec90flat-160w, the paper's '220 W' assumed)")
    s.add_argument("--child", type=Path, metavar="FILE",
                   help="walk: the child as an actor (child.toml, written by exoleg fit): "
                        "passive joint moments, contracture, spasticity, their own effort; "
                        "its mass replaces --body-mass")
    s.add_argument("--expected-stride", type=_within(*STRIDE_TIME_RANGE, " s"),
                   help="walk: the stride the walking controller expects until it has "
                        "measured the child's, s (a child's later session: their own; "
                        "default --stride-time, the walk planned)")
    s.add_argument("--sensor-fault", type=_sensor_fault, action="append", default=[],
                   metavar="SPEC", help="walk: a fault of the foot board's sensors, "
                   "repeatable: CHANNEL:KIND[@START[..END]][=VALUE] -- channel heel, met1, "
                   "met5, hallux, fsrs, gyro, accel, insole (the other foot's, when "
                   "fitted) or board (all); kind dead (reads VALUE), "
                   "missing, frozen, offset (+VALUE) or drift (VALUE per s); times in s; an "
                   "FSR's VALUE a fraction of full scale, the gyroscope's rad/s, the "
                   "accelerometer's m/s^2. E.g. heel:dead@2")
    s.set_defaults(func=cmd_simulate,
                   variant_defaults={a.dest: a.default for a in s._actions if a.dest in APPLIES})
