"""``exoleg validate``: the model against the paper, Pinocchio and MuJoCo; ``--gait-
phase``: the detector against the true contacts."""

from __future__ import annotations

import argparse
import math
from typing import Any

from exoleg.cli._common import _count, _device_option, _say, _table
from exoleg.cli.simulate_walk import _DETECTION_HEADER, _detection_rows
from exoleg.errors import ParameterError


def _ms(x: float) -> str:
    return "-" if x != x else f"{x:.0f}"


def _pct(x: float) -> str:
    """A share as a percentage; "-" when there is none (no strides to count)."""
    return f"{100 * x:.0f} %" if x == x else "-"


# --------------------------------------------------------------------------- validate


def _fault_table(cases: dict[str, list[dict[str, Any]]], title: str) -> None:
    """Initial contact and toe off per replayed case
    (:func:`exoleg.validate.gait_phase.fault_cases`)."""
    _table([[case if i == 0 else "", r["event"], _ms(r["median_abs_error_ms"]),
             _ms(r["p95_abs_error_ms"]), str(r["missed"]), str(r["false"]),
             _pct(r["in_strides"])]
            for case, table in cases.items()
            for i, r in enumerate(x for x in table if x["event"] in ("initial contact",
                                                                      "toe off"))],
           ["sensor fault", "event", "median |error| ms", "p95 |error| ms", "missed",
            "extra", "in strides"], title=title)


def _landing_in_words(h: dict[str, float]) -> str:
    """The heel strike's load against the children measured: at 2 % of the stride
    within one SD of theirs, or harder or softer (by how many SDs); one body weight
    sooner or later."""
    d = h["at_2pct_bw"] - h["source_2pct_bw"]
    sds = f" ({abs(d) / h['source_2pct_sd']:.1f} SD {'above' if d > 0 else 'below'} their mean)"
    at2 = ("lands within one SD of the children measured" if abs(d) <= h["source_2pct_sd"]
           else "lands harder than the children measured" + sds if d > 0
           else "lands softer than the children measured" + sds)
    return at2 + (", reaching one body weight sooner" if h["to_1bw_ms"] < h["source_to_1bw_ms"]
                  else ", reaching one body weight no sooner")


def _transparency(strides: int, device: Any) -> int:
    """``validate --transparency``: the budget and the walk's table
    (:mod:`exoleg.validate.transparency`) on the shipped device or the folder ``device``;
    0 when the goal is met."""
    from exoleg.params.records import JOINTS
    from exoleg.validate.transparency import GOAL_NM_PER_KG, PREX_NM, SETTLE_STRIDES, evaluate

    v = evaluate(strides=strides, device=device)
    _table([[b["joint"], f"{b['need_rms_Nm']:.1f} / {b['need_peak_Nm']:.1f}",
             f"{b['inertial_rms_Nm']:.1f}", f"{b['limit_Nm']:.1f}",
             f"{100 * b['beyond_share']:.0f} %", f"{b['floor_Nm_per_kg']:.3f}",
             f"{b['rotor_inertia_kgm2']:.3f} / {b['fits_kgm2']:.3f}"] for b in v.budget],
           ["joint", "device alone needs RMS / peak N m", "of it inertial RMS N m",
            "drive's limit N m", "cycle beyond it", "floor N m/kg",
            "rotor's inertia now / that fits kg m^2"],
           title=f"the budget: the device alone along the normative gait at 1.1 s strides, "
                 f"{v.child} ({v.body_mass:.1f} kg)")
    from exoleg.validate.transparency import LIMITS

    reach = v.rows[-1]["rms_Nm_per_kg"]
    _table([[b["joint"], *(f"{b['floors_Nm_per_kg'][k]:.3f}" for k in LIMITS),
             f"{b['floor_all_Nm_per_kg']:.3f}", f"{b['floor_loop_Nm_per_kg']:.3f}",
             f"{b['gear_mode_hz']:.0f}", f"{reach[b['joint']]:.3f}",
             f"{100 * (reach[b['joint']] / b['floor_loop_Nm_per_kg'] - 1):+.0f} %"]
            for b in v.floors],
           ["joint", *(f"{k} N m/kg" for k in LIMITS), "all together N m/kg",
            "with the loop's lag N m/kg", "gear's first mode Hz", "the law reaches N m/kg",
            "above the loop's floor"],
           title="the physical floor along the walk's own motion: what each limit of the "
                 "actuators' datasheets alone leaves the child of the device alone's need "
                 "(RMS per kg), all of them together (the drive's envelope), and with the "
                 "loop's lag (a law that knows the device exactly, a tick behind at 1 kHz, "
                 "through the drive's torque loop); the rotor on the gear's stiffness "
                 "(bounding any torque loop's bandwidth); beside the law's residual on the "
                 "same motion")
    behind = [b for b in v.floors if not math.isnan(b["floor_rotor_Nm_per_kg"])]
    if behind:
        _say("behind the series springs, their rotors must follow the links: what any law "
             "leaves the child -- even knowing the walk ahead, with the motors' current "
             "limit alone -- "
             + ", ".join(f"{b['joint']} {b['floor_rotor_Nm_per_kg']:.3f}" for b in behind)
             + " N m/kg RMS, against the law's "
             + ", ".join(f"{b['joint']} {reach[b['joint']]:.3f}" for b in behind))
    _say("of the device's need, the pelvis's vertical acceleration asks "
         + ", ".join(f"{b['joint']} {b['pelvis_Nm_per_kg']:.3f}" for b in v.floors)
         + " N m/kg RMS: the transparent law leaves it to the child (no sensor on the "
           "device reads it); a law that knew all the rest, a tick late, would leave "
         + ", ".join(f"{b['joint']} {b['floor_unread_pelvis_Nm_per_kg']:.3f}"
                     for b in v.floors) + " N m/kg")
    _table([[r["parts"] + (" (stopped)" if r["stopped"] else ""),
             *(f"{r['walked_Nm_per_kg'][j]:.3f}" for j in JOINTS),
             *(f"{r['rms_Nm_per_kg'][j]:.3f}" for j in JOINTS)] for r in v.rows],
           ["transparent law's parts", *(f"{j} walked" for j in JOINTS),
            *(f"{j} same motion" for j in JOINTS)],
           title=f"the cuffs' torque RMS over {strides} strides in the transparent mode "
                 f"(the first {SETTLE_STRIDES} left out), N m/kg, with only each row's parts: "
                 "walked so (a walk each), and on the law's own walk, what the device "
                 "needs there less the row's parts as commanded (a what-if: the child "
                 "walks otherwise without them, and the cuffs' feedback reacts to the walk "
                 "it is in); the last row is the law's own walk")
    law = v.rows[-1]
    if "commanded_Nm_per_kg" in law:
        _say("the law's whole command on its own walk would leave "
             + ", ".join(f"{j} {law['commanded_Nm_per_kg'][j]:.3f}" for j in JOINTS)
             + " N m/kg; delivered by the drives (their loops' lag, their limits) it "
               "leaves " + ", ".join(f"{j} {law['rms_Nm_per_kg'][j]:.3f}" for j in JOINTS))
    h = v.loading
    _say(f"the heel strike: the sole's vertical load {h['at_2pct_bw']:.2f} body weights 2 % "
         f"of the stride after contact (Schwartz et al. 2008, free speed: "
         f"{h['source_2pct_bw']:.2f} +- {h['source_2pct_sd']:.2f}), one body weight "
         f"within {h['to_1bw_ms']:.0f} ms of it (theirs ~{h['source_to_1bw_ms']:.0f} ms; median "
         f"of {h['contacts']:.0f} contacts, the device's weight included): the simulated "
         f"child {_landing_in_words(h)}; the 45 ms after each contact hold "
         + ", ".join(f"{b['joint']} {100 * b['gear_floor_at_landing']:.0f} %" for b in v.floors)
         + " of the floor beyond the gears' repeated peak (the plant's landing, not the law)"
         + _touches(h))
    _say(f"the same {100 * h['landing_share']:.0f} % of the walk hold "
         + ", ".join(f"{j} {100 * x:.0f} %" for j, x in h["cuffs_at_landing"].items())
         + " of the cuffs' torque (squared); outside them the law leaves "
         + ", ".join(f"{j} {x:.3f}" for j, x in h["cuffs_outside_Nm_per_kg"].items())
         + " N m/kg RMS, over the loop's floor there of "
         + ", ".join(f"{b['joint']} {b['floor_loop_outside_Nm_per_kg']:.3f}" for b in v.floors))
    _other_landing(strides, device, v)
    rigid = [(j, g) for j, g in enumerate(v.gears) if g["alone"] is not None]
    share, hz = v.console["inertia_share"], v.console["accel_filter_hz"]
    if rigid:
        _table([[g["joint"], *(f"{g[k][0]:.0f} Hz, {g[k][1]:+.3f}" for k in ("alone", "worn")),
                 f"{_span(*share[j])} at {_span(*hz[j])} Hz"]
                for j, g in rigid],
               ["joint", "the device alone", "worn (the cuffs rigid)",
                "the console allows this child (share, estimate)"],
               title="the law on the gears' stiffness: each joint's least-damped mode (its "
                     "frequency, its damping ratio) with the inertia's share and the "
                     "friction's compensation read from the joint's encoder, the worse of "
                     "a command on time and a bus's cycle late; a negative ratio grows "
                     "unless the gear's own damping, which no datasheet held gives, is "
                     "larger; the console allows the share and estimate only where each "
                     "mode stays damped or no less damped than with the device's own")
    _say("at the drive's limit: " + ", ".join(f"{j} {100 * x:.0f} %"
                                            for j, x in v.saturated.items())
         + ("; the safety layer stopped the walk" if v.fault else "; no safety event"))
    _say(f"goal: <= {GOAL_NM_PER_KG} N m/kg RMS at every joint (Lerner et al. 2018, a CP "
         f"ankle exoskeleton in zero-torque mode: 0.015-0.036); P.REX < {PREX_NM} N m "
         "(Chen et al. 2021): " + ("met" if v.met else "not met"))
    return 0 if v.met else 1


def _touches(h: dict[str, Any]) -> str:
    """The heel strikes' line's warning when the foot touched the belt in swing."""
    n = int(h["swing_touches"])
    return (f"; THE FOOT TOUCHED THE BELT IN SWING {n} times (loads shorter than a "
            "stance: the toe catching the belt -- a trip, on a child)") if n else ""


def _other_landing(strides: int, device: Any, v: Any) -> None:
    """The floors and the law of ``validate --transparency``'s walk ``v`` again with the
    other leg letting the child down the other way
    (:data:`~exoleg.device.ground.LANDINGS`): how much of each is the simulated
    landing's."""
    from exoleg.device.ground import LANDINGS
    from exoleg.validate.transparency import LIMITS, evaluate

    current = LIMITS[1]  # the drive's current limit
    other = next(k for k in LANDINGS if k != v.landing)
    o = evaluate(strides=strides, device=device, landing=other)
    reach, h = o.rows[-1]["rms_Nm_per_kg"], o.loading
    out = h["cuffs_outside_Nm_per_kg"]
    _table([[b["joint"], f"{b['floors_Nm_per_kg'][current]:.3f}",
             f"{b['floor_all_Nm_per_kg']:.3f}", f"{b['floor_loop_Nm_per_kg']:.3f}",
             f"{reach[b['joint']]:.3f}",
             f"{100 * (reach[b['joint']] / b['floor_loop_Nm_per_kg'] - 1):+.0f} %",
             f"{out[b['joint']]:.3f} / {b['floor_loop_outside_Nm_per_kg']:.3f}"]
            for b in o.floors],
           ["joint", f"{current} N m/kg", "all together N m/kg",
            "with the loop's lag N m/kg", "the law reaches N m/kg", "above the loop's floor",
            "outside the landings: law / loop's floor"],
           title=f"the same walk with the other leg's landing {other!r} (walking.toml "
                 f"[support] landing; this device's: {v.landing!r}): the heel bears "
                 f"{h['at_2pct_bw']:.2f} body weights 2 % of the stride after contact, one "
                 f"body weight after {h['to_1bw_ms']:.0f} ms -- the simulated child "
                 f"{_landing_in_words(h)}" + _touches(h)
                 + ("; the safety layer stopped the walk" if o.fault else ""))


def _cp_child(strides: int) -> int:
    """``validate --cp-child``: the shipped real child with CP against exoleg's dynamics
    and its simulated child (:mod:`exoleg.validate.cp_child`); 0 when both goals are
    met."""
    import numpy as np

    from exoleg.params.records import JOINTS
    from exoleg.reference.scores import cp_child_cycle, gait_scores, sagittal_pattern
    from exoleg.validate.cp_child import (
        HEIGHT_M,
        MASS_KG,
        inverse_dynamics,
        inverse_dynamics_3d,
        walk_match,
    )

    w = walk_match(strides=strides)  # first: a count it refuses is said before any table
    three = inverse_dynamics_3d()
    names = {"hip_flex_r": "hip flexion", "hip_add_r": "hip adduction",
             "hip_rot_r": "hip rotation", "knee_flex_r": "knee flexion"}
    _table([[names[c], f"{three['rms_shipped'][i]:.1f}", f"{three['rms_error'][i]:.1f}",
             f"{100 * three['relative'][i]:.1f} %"]
            for i, c in enumerate(three["coordinates"]) if c in names],
           ["moment", "shipped RMS N m", "exoleg's error RMS N m", "relative"],
           title="inverse dynamics of predictcpgait subject 1 (Falisse et al. 2020) on "
                 "their own OpenSim model's right leg, in 3D, through the shipped motion and "
                 "ground reaction force (the ankle's and subtalar's moments given: they place "
                 "the centre of pressure, which is not shipped; no free moment)")
    idyn = inverse_dynamics()
    _table([[j, f"{idyn['rms_shipped'][i]:.1f}", f"{idyn['rms_error'][i]:.1f}",
             f"{100 * idyn['relative'][i]:.0f} %"] for i, j in enumerate(JOINTS[:2])],
           ["joint", "shipped moment RMS N m", "exoleg's error RMS N m", "relative"],
           title=f"the same on exoleg's planar leg for {MASS_KG:g} kg, {HEIGHT_M:g} m "
                 "(the sagittal plane only: the child's hip is adducted and rotated up to "
                 "17 and 18 deg in stance; the ankle's moment given)")
    cyc = cp_child_cycle()
    pattern, za, zk = sagittal_pattern(cyc)
    _, gps = gait_scores(cyc)
    _say(f"the real child: GPS (3 sagittal variables) {gps:.1f} deg; {pattern} (Sangeux "
         f"2015: ankle {za:+.1f}, knee {zk:+.1f} SD in mid-stance)")
    own = w.trials_within
    _table([[j, f"{100 * w.within[i]:.0f} %", f"{w.rms_deg[i]:.1f}",
             " / ".join(f"{100 * v:.0f}" for v in own[:, i]) + " %"]
            for i, j in enumerate(JOINTS)],
           ["joint", "samples within the real child's mean +- 1 SD", "RMS deg",
            f"the real child's own {len(own)} trials, the same way"],
           title=f"the simulated child (GMFCS II, mild spasticity, the predictcpgait "
                 f"contracture) intending this gait, in the device in transparent mode, on "
                 f"a treadmill matched to it: "
                 f"{w.strides} strides; {w.pattern} (the real child: {w.real_pattern}); "
                 f"{100 * w.forefoot_first:.0f} % of contacts forefoot first"
                 + ("; the safety layer stopped the walk" if w.fault else ""))
    for row in w.detection:
        _say(f"the detector (FSRs and the foot's IMU, x1 noise), {row['event']}: "
             f"{row['detected']} of {row['true']}, median {row['median_abs_error_ms']:.0f} "
             f"ms, p95 {row['p95_abs_error_ms']:.0f} ms off the true ones")
    goal_id = bool(np.all(three["relative"][[0, 3]] <= 0.10))
    goal_walk = bool(np.all(w.within >= 0.90))
    met = int(np.sum(np.all(own >= 0.90, axis=1)))
    _say(f"goals: inverse dynamics (3D) within 10 % RMS at hip and knee: "
         f"{'met' if goal_id else 'not met'}; the simulated child within the real one's "
         f"mean +- 1 SD at >= 90 % of the cycle at every joint: "
         f"{'met' if goal_walk else 'not met'} (the real child's own trials: {met} of "
         f"{len(own)} meet it)")
    return 0 if goal_id and goal_walk else 1


#: validate's checks (one at a time; none: the model's) and the options each takes
MODES = {"gait_phase": ("strides", "other_foot"), "transparency": ("strides", "device"),
         "cp_child": ("strides",), "identify": ("children",), "": ("quick",)}


def _check_options(args: argparse.Namespace) -> None:
    """One check at a time, and each option with a check that takes it (a second check
    or an option no check takes was dropped without a word)."""
    def flag(name: str) -> str:
        return "--" + name.replace("_", "-")

    modes = [m for m in MODES if m and getattr(args, m)]
    if len(modes) > 1:
        raise ParameterError("exoleg validate", flag(modes[1]), f"one check at a time: "
                             f"{flag(modes[0])} and {flag(modes[1])} were both given")
    mode = modes[0] if modes else ""
    for option in ("quick", "strides", "children", "other_foot", "device"):
        given = getattr(args, option) not in (None, False)
        if given and option not in MODES[mode]:
            takers = [flag(m) if m else "the model's checks (exoleg validate alone)"
                      for m, o in MODES.items() if option in o]
            raise ParameterError("exoleg validate", flag(option), "goes with "
                                 + " or ".join(takers))


def cmd_validate(args: argparse.Namespace) -> int:
    _check_options(args)
    if args.cp_child:
        return _cp_child(args.strides or 12)
    if args.identify:
        from exoleg.cli._common import _Progress
        from exoleg.validate.identify import evaluate as identify_children
        from exoleg.validate.identify import summary

        progress = _Progress()
        try:
            done = identify_children(args.children or 100,
                                     progress=lambda f: progress("identify", f))
        finally:
            progress.stop()
        _table(summary(done), ["", "median", "p95", "worst"],
               title=f"identification over {len(done)} simulated children (offline: encoders, "
                     "a 41 ms differentiator, torque noise 1 % of continuous, each child's "
                     "passive moments and their level's spasticity held at their model); "
                     "the controllers on the true leg given each model")
        carried = [r for r in done if r.walk_identified_pct == r.walk_identified_pct]
        _say(f"walking: {len(carried)} of {len(done)} children carried by the device with "
             "their true leg (tracking RMS within 10 deg, no fault; the others are not "
             "compared)")
        _say("the issue's goal: G error RMS <= 1 %, max <= 3 %; walking tracking with the "
             "identified G within 10 % of the true G's")
        ok = all(r.g_max_pct <= 3.0 and r.g_rms_pct <= 1.0 for r in done) and all(
            r.walk_identified_pct <= 10.0 for r in carried)
        return 0 if ok else 1
    if args.transparency:
        return _transparency(args.strides or 10, args.device)
    if args.gait_phase:
        from exoleg.validate.gait_phase import evaluate

        v = evaluate(strides=args.strides or 20, other_foot=args.other_foot)
        if args.other_foot:
            _say("both feet's FSRs: the unassisted foot's insole fitted in every walk and "
                 "replay (its load bounds the device's foot's stance: no lift while the "
                 "other foot is off the ground)")
        rows, rows_ok, runs, faults = v.rows, v.rows_ok, v.runs, v.faults
        _table([[r.child, f"x{r.noise:g}", f"{r.stride_time:g} s", str(r.strides),
                 "stopped by the safety layer" if r.fault else "ok"] for r in runs],
               ["child", "sensor noise", "stride", "strides", "walk"])
        _table(_detection_rows(rows), _DETECTION_HEADER,
               title="gait-phase detection (FSRs and the foot's gyroscope) against the true "
                     "contacts, all runs")
        if rows_ok and len(rows_ok) != len(rows) or any(r.fault for r in runs):
            _table(_detection_rows(rows_ok), _DETECTION_HEADER,
                   title="the same, runs the safety layer did not stop")
        _fault_table(faults, "sensor faults, replayed through the detector (FSRs and the "
                             "foot's IMU) over the same walks")
        for st, table in v.slow.items():
            _table(_detection_rows(table), _DETECTION_HEADER,
                   title=f"the same children walking slowly, strides of {st:g} s (x1 noise)")
            _fault_table(v.slow_sources[st], f"strides of {st:g} s: each source alone, "
                                             "replayed over the same walks")
        for label, cases in v.worst.items():
            _fault_table(cases, f"{label} (x1 noise): both sources and each alone")
        _fault_table(v.closed, "sensor faults injected into the walks (closed loop: the "
                               "controller walking on the faulted readings; x1 noise)")
        for case, who in v.closed_stopped.items():
            if who:
                _say(f"{case}: stopped by the safety layer: {', '.join(who)}")
        _say("published, shank gyroscope: initial contact -25 ms, foot off < 75 ms, > 98 % "
             "detected (Catalfamo et al. 2010); children with CP: onset < 100 ms, > 99 % of "
             "phases (Behboodi et al. 2019)")
        return 1 if any(r.fault for r in runs) or any(v.closed_stopped.values()) else 0
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


def add_parser(sub: Any) -> None:
    """Add ``exoleg validate`` to the subcommands ``sub``."""
    v = sub.add_parser("validate", help="check the model against the paper, Pinocchio, MuJoCo")
    v.add_argument("--quick", action="store_true", help="fewer random legs and states")
    v.add_argument("--gait-phase", action="store_true",
                   help="the gait-phase detector against the true contacts: children x noise")
    v.add_argument("--other-foot", action="store_true",
                   help="with --gait-phase: the unassisted foot's insole fitted too (both "
                        "feet's FSRs) in every walk and replay")
    v.add_argument("--strides", type=_count(1, 1000), metavar="N",
                   help="with --gait-phase (default 20), --transparency (default 10, at "
                        "least 3) or --cp-child (default 12, at least 4): strides per "
                        "walk, 1-1000")
    v.add_argument("--transparency", action="store_true",
                   help="the transparent mode: the device's budget and a typically "
                        "developing child walking in it")
    _device_option(v, "with --transparency, the device judged")
    v.add_argument("--cp-child", action="store_true",
                   help="the shipped real child with CP (Falisse et al. 2020): inverse "
                        "dynamics on their gait, and the simulated child walking it")
    v.add_argument("--identify", action="store_true",
                   help="identification of the leg over simulated children of the design "
                        "range (offline)")
    v.add_argument("--children", type=_count(1, 10000), metavar="N",
                   help="with --identify: how many children, 1-10000 (default 100)")
    v.set_defaults(func=cmd_validate)


def _span(lo: float, hi: float) -> str:
    """lo-hi, or one number when they are one."""
    return f"{lo:g}" if lo == hi else f"{lo:g}-{hi:g}"
