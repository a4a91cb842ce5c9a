"""One run of a study, and one task (a batch of runs): the child, the device variant, the
walking controller and the walk a run's axis values name, walked with the whole device
(:func:`exoleg.sim.walk.simulate_walk`), and the row of figures it is judged by.

A run that fails (a child the charts refuse, a non-finite state) is a row with its
error, never a lost task. Rows hold no wall times: the same run gives the same row on
every machine and scheduler.
"""

from __future__ import annotations

import dataclasses
import functools
import warnings
from typing import Any

import numpy as np

from exoleg.errors import ExolegError, ParameterError
from exoleg.params.records import JOINTS

#: Per joint, the figures a row keeps (:func:`exoleg.sim.metrics.actuator_peaks`'s keys
#: and the tracking error), each as ``{name}_{joint}``.
JOINT_METRICS = ("rms_tracking_error_deg", "peak_torque_Nm", "torque_limit_Nm",
                 "rms_torque_Nm", "continuous_torque_Nm", "peak_speed_deg_s",
                 "max_velocity_deg_s", "rms_current_A", "nominal_current_A",
                 "winding_max_C", "gear_peak_Nm", "momentary_peak_Nm", "ticks_at_envelope",
                 "safety_winding_max_C", "safety_gear_peak_Nm")
#: Whole-run figures: the device fits the child (geometry), walked (no safety fault), the
#: fault (its kind and joint, '' for none) and when, the run's ticks and those in which
#: the safety layer clipped torque, derated a motor or saw a gear beyond its momentary
#: peak, the steps detected, the foot's touches of the belt in swing while walking
#: (:meth:`~exoleg.sim.walk.WalkResult.swing_touches`: the toe catching it, a trip on a
#: child), and the sampled loop's stability margin: the largest h lambda(M^-1 Kd) of the
#: stance and swing damping over the run's postures, the leg's mass matrix with the
#: actuators' reflected inertia (a held velocity feedback is stable while it is below 2:
#: docs/conventions.md).
RUN_METRICS = ("fits", "walked", "fault", "fault_time_s", "ticks", "ticks_torque_clipped",
               "ticks_derated", "ticks_gear_beyond_momentary", "steps", "swing_touches",
               "stability_margin", "error")
#: The support (0-1, :mod:`exoleg.control.assist`) per stride, mean over the joints: the
#: first and the last stride, and the last stride's per joint as ``support_last_{joint}``;
#: the safety layer's events while walking (:func:`exoleg.sim.metrics.safety_events`): how
#: many kinds fired and their names ('' for none).
SUPPORT_METRICS = ("support_first", "support_last", "safety_events", "safety_event_kinds")
#: Per joint, the cuffs' torque while walking (:mod:`exoleg.child.interaction`), RMS
#: and peak per kg of body mass, as ``interaction_{rms,peak}_Nm_per_kg_{joint}``.
INTERACTION_METRICS = ("interaction_rms_Nm_per_kg", "interaction_peak_Nm_per_kg")


def _child(run: dict[str, Any]) -> Any:
    from exoleg.sizing import Child
    from exoleg.sizing.child import DesignRangeWarning, population_child

    prof = run.get("profile")
    if prof is not None:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", DesignRangeWarning)
            return Child(age=prof["age"], sex=prof["sex"], height=prof["height"],
                         mass=prof["mass"], gmfcs=prof["gmfcs"], name=prof["name"])
    from exoleg.study.spec import GROUPS

    level = GROUPS.index(run["group"])
    return population_child(level or None, run["sex"], run["age"], run["percentile"])[0]


@functools.lru_cache(maxsize=8)
def _units(hip_motor: str, device: str | None = None) -> tuple[Any, ...]:
    """The units of the device folder ``device`` (None: the shipped ones) with the hip's
    motor variant (read once per process)."""
    from exoleg.device.actuator import hip_variant, paper_actuators

    return (hip_variant(hip_motor), *paper_actuators(device))


def device_variant(run: dict[str, Any], device: str | None = None) -> tuple[Any, ...]:
    """The three actuation units a run names: the hip's motor variant, each joint's gear
    ratio (the ratings of the shipped gear of that ratio: 50 the knee's CSF-17-50, 100
    the hip's CSF-17-100, 120 the ankle's), the bus voltage. A study on a device folder
    (``device``) walks the folder's own units: it fixes the actuation
    (:meth:`~exoleg.study.spec.Study.on_device` refuses the device axes with it)."""
    if device is not None:
        return _units(run["hip_motor"], device)[1:]
    hip, *shipped = _units(run["hip_motor"], device)
    by_ratio = {a.ratio: a for a in shipped}
    gear = ("gear", "ratio", "efficiency", "gear_input_inertia", "gear_rated_torque",
            "repeated_peak_torque", "momentary_peak_torque", "max_input_speed_rpm",
            "backdriving_torque", "gear_stiffness")
    out = []
    for a, joint in zip((hip, *shipped[1:]), JOINTS, strict=True):
        g = by_ratio[run[f"{joint}_ratio"]]
        sources = {**a.sources, **{k: g.sources[k] for k in gear if k in g.sources},
                   "bus_voltage": "the study's axis"}
        out.append(dataclasses.replace(a, **{k: getattr(g, k) for k in gear},
                                       bus_voltage=run["bus_voltage"], sources=sources))
    return tuple(out)


def actor(run: dict[str, Any], child: Any) -> Any:
    """The child as an actor (:class:`~exoleg.child.model.ChildModel`) when the run's
    ``child`` axis says so (its impairments from the run's axes), else None."""
    if run["child"] != "actor":
        return None
    from exoleg.child.model import ChildModel

    return ChildModel.of(child, run["contracture"], run["spasticity"], int(run["crouch"]),
                         float(run["strength"]))


def _gains(run: dict[str, Any], device: str | None = None) -> Any:
    from exoleg.control.hierarchy import WalkGains

    g = WalkGains.default(device)
    return dataclasses.replace(g, kp_stance=g.kp_stance * run["kp_scale"],
                               kp_swing=g.kp_swing * run["kp_scale"],
                               kd_stance=g.kd_stance * run["kd_scale"],
                               kd_swing=g.kd_swing * run["kd_scale"], support=run["support"])


def _flat(run: dict[str, Any]) -> dict[str, Any]:
    """A run's axis values as columns (a profile as its name, height and mass)."""
    out = {k: v for k, v in run.items() if k != "profile"}
    if "profile" in run:
        p = run["profile"]
        out["profile"] = p["name"]
    return out


def empty_row(run_id: int, task: int, run: dict[str, Any]) -> dict[str, Any]:
    """A run's row before its figures: its id, task, axis values; NaN figures."""
    row: dict[str, Any] = {"run": run_id, "task": task, **_flat(run),
                           "height_m": np.nan, "mass_kg": np.nan}
    for m in (*JOINT_METRICS, *INTERACTION_METRICS, "support_last"):
        for j in JOINTS:
            row[f"{m}_{j}"] = np.nan
    row.update(support_first=np.nan, support_last=np.nan, safety_events=-1,
               safety_event_kinds="")
    row.update(fits=False, walked=False, fault="", fault_time_s=np.nan, ticks=-1,
               ticks_torque_clipped=-1, ticks_derated=-1, ticks_gear_beyond_momentary=-1,
               steps=-1, swing_touches=-1, stability_margin=np.nan, error="")
    return row


def run_one(run_id: int, task: int, run: dict[str, Any], strides: int,
            device: str | None = None) -> dict[str, Any]:
    """Walk one run (``strides`` strides after 1 s of standing) on the device of the folder
    ``device`` (None: the shipped one) and judge it; a failure is the row's ``error``."""
    from exoleg.control.controllers import PD
    from exoleg.control.gait_phase import Event
    from exoleg.control.safety import Fault, Limited, joint_name
    from exoleg.control.transparency import SUPPORT_NAMES, SupportMode
    from exoleg.sim.closed_loop import sampled_stability
    from exoleg.sim.metrics import (
        interaction_summary,
        safety_events,
        support_per_stride,
        walk_peaks,
    )
    from exoleg.sim.walk import simulate_walk
    from exoleg.sizing.fit import fit_device
    from exoleg.sizing.personal import personalized_leg

    row = empty_row(run_id, task, run)
    try:
        child = _child(run)
        row.update(height_m=child.height, mass_kg=child.mass)
        fit = fit_device(child)
        leg = personalized_leg(child, fit)
        gains = _gains(run, device)
        mode = SUPPORT_NAMES[run["controller"]]
        who = actor(run, child)
        if mode == SupportMode.TRANSPARENT and who is None:
            raise ParameterError("study run", "controller", "transparent needs child = "
                                 "\"actor\" (a passive leg in a transparent device falls)")
        r = simulate_walk(leg, child.mass, strides=strides, speed=run["speed"],
                          stride_time=run["stride_time"], noise_scale=run["noise"],
                          seed=run["seed"], actuators=device_variant(run, device),
                          gains=gains, child=who, support_mode=mode,
                          assist_law=run["assist_law"], device=device)
    except (ExolegError, ValueError, ArithmeticError) as e:
        row["error"] = f"{type(e).__name__}: {e}"
        return row
    if device is not None:  # the actuation the folder fixed, not the axes' defaults
        hip, knee, ankle = r.actuators
        row.update(hip_motor=hip.motor, bus_voltage=hip.bus_voltage, hip_ratio=hip.ratio,
                   knee_ratio=knee.ratio, ankle_ratio=ankle.ratio)
    dt = float(r.t[1] - r.t[0])
    status = r.safety_status
    for p, j in zip(walk_peaks(r), JOINTS, strict=True):
        for m in JOINT_METRICS:
            row[f"{m}_{j}"] = float(p[m])
    for p in interaction_summary(r):
        row[f"interaction_rms_Nm_per_kg_{p['joint']}"] = p["rms_Nm_per_kg"]
        row[f"interaction_peak_Nm_per_kg_{p['joint']}"] = p["peak_Nm_per_kg"]
    per_stride = support_per_stride(r.t, r.support_level, r.strikes())
    if len(per_stride):
        row.update(support_first=float(per_stride[0].mean()),
                   support_last=float(per_stride[-1].mean()))
        for x, j in zip(per_stride[-1], JOINTS, strict=True):
            row[f"support_last_{j}"] = float(x)
    events = safety_events(r.t, status, r.walk_start)
    row.update(safety_events=len(events),
               safety_event_kinds=",".join(e["event"] for e in events))
    postures = r.q[::10]
    margin = max(sampled_stability(r.plant.leg, PD(Kp=kp, Kd=kd), dt, postures)
                 for kp, kd in ((gains.kp_stance, gains.kd_stance),
                                (gains.kp_swing, gains.kd_swing)))
    faulted = np.nonzero(r.fault != Fault.NONE)[0]
    if len(faulted):
        k = int(faulted[0])
        f = Fault(int(r.fault[k]))
        jn = joint_name(f, int(r.fault_joint[k]))
        row.update(fault=f.name + (f" ({jn})" if jn else ""), fault_time_s=float(r.t[k]))
    row.update(fits=bool(fit.fits), walked=not len(faulted), ticks=len(r.t),
               ticks_torque_clipped=int(((status & Limited.TORQUE) > 0).sum()),
               ticks_derated=int(((status & Limited.DERATED) > 0).sum()),
               ticks_gear_beyond_momentary=int(((status & Limited.GEAR_PEAK) > 0).sum()),
               steps=int(((r.events & Event.IC) > 0).sum()),
               swing_touches=len(r.swing_touches()), stability_margin=margin)
    return row


def run_task(task: int, runs: list[tuple[int, dict[str, Any]]], strides: int,
             device: str | None = None) -> list[dict[str, Any]]:
    """A task: its runs, each (run id, axis values), one after the other in this process
    (each walk one compiled loop) on the device of the folder ``device``; one row per run,
    failures included."""
    return [run_one(i, task, run, strides, device) for i, run in runs]
