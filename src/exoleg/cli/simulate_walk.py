"""``exoleg simulate --walk``: a fitted child (or the paper's leg) walking on the treadmill
with the whole device."""

from __future__ import annotations

import argparse
import time
from typing import Any

from exoleg.cli._common import _child_on_leg, _mass_of, _read_leg, _say, _table
from exoleg.cli._runs import device_actuators, write_run
from exoleg.sim.metrics import interaction_summary


def _simulate_walk(args: argparse.Namespace) -> int:
    """``simulate --walk``: a fitted child (or the paper's leg) walking on the treadmill
    with the whole device (:func:`exoleg.sim.walk.simulate_walk`)."""
    import dataclasses

    import numpy as np

    import exoleg
    from exoleg.control.assist import AssistSettings
    from exoleg.control.safety import Limited, fault_event
    from exoleg.control.transparency import SUPPORT_NAMES
    from exoleg.device.sensors import FROZEN_S
    from exoleg.errors import ParameterError
    from exoleg.params.records import JOINTS
    from exoleg.plots.figures import walk_figure
    from exoleg.sim.metrics import detection_table, safety_events, support_by_stride, walk_peaks
    from exoleg.sim.walk import simulate_walk

    t0 = time.perf_counter()
    notes: list[str] = []
    if args.leg:
        leg, warning = _read_leg(args.leg)
        notes += [warning] if warning else []
    else:
        leg = exoleg.paper_leg("simplified")
    stride = args.stride_time or 1.1
    child = None
    if args.controller == "transparent" and not args.child:
        raise ParameterError("exoleg simulate --walk", "--controller",
                             "transparent leaves the leg to the child: give --child (a "
                             "passive leg in a transparent device falls)")
    if args.child:
        from exoleg.child.model import ChildModel

        child = ChildModel.load(args.child)
        _child_on_leg(child, args.leg, "exoleg simulate --walk")
        given = args.body_mass if args.body_mass != args.variant_defaults["body_mass"] else None
        args.body_mass = _mass_of(child, given, "exoleg simulate --walk")
    r = simulate_walk(leg, args.body_mass, strides=args.strides, speed=args.speed or "Free",
                      stride_time=stride, noise_scale=args.noise, seed=args.seed,
                      ankle_height=args.ankle_height / 100, device=args.device,
                      actuators=device_actuators(args), child=child,
                      support_mode=SUPPORT_NAMES[args.controller],
                      faults=tuple(args.sensor_fault), expected_stride=args.expected_stride)
    rows = detection_table([r])
    peaks = walk_peaks(r)
    over = (r.safety_status & Limited.GEAR_PEAK) > 0
    fault = bool(np.any(r.safety_status & Limited.FAULT))
    if fault:
        k = int(np.argmax(r.safety_status & Limited.FAULT))
        why = fault_event(r.fault[k], r.fault_joint[k])
        if r.board_frozen >= 0:  # the watch's E-stop
            why = (f"the foot board's readings froze -- every sensor repeating bit for bit "
                   f"for {FROZEN_S:g} s -- at t = {r.board_frozen:.3f} s: the sensor watch's "
                   "E-stop, as on the device")
        notes.append(f"the safety layer stopped the walk at t = {r.t[k]:.3f} s ({why}); "
                     "torque was off from then on")
    for e in safety_events(r.t, r.safety_status):
        if e["event"] in ("cuff", "cuff_stop"):  # the cuffs' limit (safety.toml [cuffs])
            notes.append(f"the {e['text']}: from t = {e['first_s']:.3f} s, {e['ticks']} "
                         "ticks")
    touches = r.swing_touches()
    if len(touches):  # a trip, on a child (sim.events.loads)
        notes.append(f"the foot touched the belt in swing {len(touches)} times (loads "
                     f"shorter than a stance, the first at t = {touches[0]:.3f} s): on a "
                     "child, a trip")
    inter = interaction_summary(r)
    per_kg = r.cuff_limit
    walking = r.t >= r.walk_start
    cuffs = [{"joint": j, "peak_Nm": float(np.nanmax(np.abs(r.cuff[walking, i]), initial=0.0)),
              "peak_Nm_per_kg": float(np.nanmax(np.abs(r.cuff[walking, i]), initial=0.0)
                                      / args.body_mass),
              "limit_Nm_per_kg": float(per_kg[i])} for i, j in enumerate(JOINTS)]
    strikes = r.strikes()
    figs = {"strides_commanded": args.strides, "body_mass_kg": args.body_mass,
            "pelvis_mass_kg": r.plant.body_mass, "belt_speed_m_s": r.plant.belt_speed,
            "safety_fault": fault, "peaks": peaks,
            "board_frozen_s": None if r.board_frozen < 0 else r.board_frozen,
            "gait_phase_detection": rows,
            "max_contact_force_N": float(r.contact_force.sum(axis=1).max()),
            "swing_touches_s": [float(x) for x in touches],
            "child": None if child is None else child.name,
            "controller": args.controller,
            "expected_stride_s": args.expected_stride or stride,
            "sensor_faults": [str(f) for f in args.sensor_fault],
            "interaction_torque": inter,
            "cuffs": cuffs,
            "interaction_torque_rms_per_kg": {f["joint"]: f["rms_Nm_per_kg"] for f in inter},
            "support_by_stride": support_by_stride(r.t, r.support_level, strikes),
            "safety_events": safety_events(r.t, r.safety_status, r.walk_start)}
    if args.controller == "aan":  # the law (the device folder's assist.toml) and its gain
        law = AssistSettings.default(args.device).law
        figs["assist_law"] = law
        if law == "proportional":  # OpenExo's K per joint, as each stride started
            figs["assist_gain_by_stride"] = {
                j: [float(r.assist_gain[np.searchsorted(r.t, s), i]) for s in strikes]
                for i, j in enumerate(JOINTS)}
    more = {}
    if child is not None:  # the cuffs' torque, the support, the child's intended gait
        from exoleg.plots.child import support_figure

        more["support"] = lambda path: support_figure(r, child, strikes, path)
    wrote = write_run(args, r, walk_figure, "walk", t0,
                       {"leg": leg.name, "figures": figs, "notes": notes,
                        "actuators": [dataclasses.asdict(a) for a in r.actuators]}, more)
    _say(f"exoleg simulate --walk --controller {args.controller}: leg '{leg.name}', body "
         f"{args.body_mass:g} kg (pelvis carries "
         f"{r.plant.body_mass:.1f} kg), {args.strides} strides of {stride:g} s on a belt at "
         f"{r.plant.belt_speed:.2f} m/s, sensor noise x{args.noise:g} (seed {args.seed})"
         + "".join(f"; {f}" for f in args.sensor_fault))
    _table([[p["joint"], f"{p['rms_tracking_error_deg']:.1f}",
             f"{p['peak_torque_Nm']:.1f} / {p['torque_limit_Nm']:.0f}",
             f"{p['rms_torque_Nm']:.1f} / {p['continuous_torque_Nm']:.0f}",
             f"{p['peak_speed_deg_s']:.0f} / {p['max_velocity_deg_s']:.0f}",
             f"{p['rms_current_A']:.2f} / {p['nominal_current_A']:g}",
             f"{p['winding_max_C']:.1f}", str(p["ticks_at_envelope"]),
             f"{p['gear_peak_Nm']:.0f} ({p['safety_gear_peak_Nm']:.0f}) / "
             f"{p['momentary_peak_Nm']:.0f}"] for p in peaks],
           ["joint", "RMS tracking deg", "peak torque / limit N m", "RMS / continuous N m",
            "speed / at the bus deg/s", "RMS current / I_N A", "winding max degC",
            "ticks at envelope", "gear peak (safety's estimate) / momentary N m"])
    if over.any():
        notes.append(f"a gear went beyond its momentary peak in {int(over.sum())} ticks (the "
                     "safety layer's estimate; safety.toml's gear_overload says what it does)")
    _table(_detection_rows(rows), _DETECTION_HEADER,
           title="gait-phase detection against the simulator's true contacts")
    for n in notes:
        _say(f"note: {n}")
    _say(wrote)
    return 1 if fault else 0


def _detection_rows(rows: list[dict[str, Any]]) -> list[list[str]]:
    def ms(v: float) -> str:
        return "-" if v != v else f"{v:+.0f}"

    def pct(v: float) -> str:
        return "-" if v != v else f"{100 * v:.1f} %"

    return [[r["event"], str(r["true"]), ms(r["mean_error_ms"]), ms(r["worst_error_ms"]),
             pct(r["missed_rate"]), pct(r["false_rate"]), pct(r["in_strides"])]
            for r in rows]


_DETECTION_HEADER = ["event", "true events", "mean error ms", "worst error ms", "missed",
                     "false", "in % of strides"]
