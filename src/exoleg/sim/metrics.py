"""What a run is judged by: the table of detected against the true contact events
(:func:`detection_table`; the true events: :func:`exoleg.sim.events.true_events`), and
what a run asked of each actuator against its limits (:func:`actuator_peaks`)."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from exoleg.params.records import JOINTS
from exoleg.sim.events import true_events  # noqa: F401  (its old home, for one release)

if TYPE_CHECKING:
    from exoleg.sim.walk import WalkResult

F64 = NDArray[np.float64]


def detection_table(results: list[WalkResult], window: float = 0.2) -> list[dict[str, Any]]:
    """Detected against true events over walks, from the walk command on
    (:func:`exoleg.control.replay.event_rows`: per event the true and detected counts,
    timing errors, missed and false rates, the share of strides it is seen in)."""
    from exoleg.control.replay import event_rows

    series = []
    for r in results:
        walking = r.t >= r.walk_start
        series.append((r.t[walking], r.events[walking], r.true_events()[walking]))
    return event_rows(series, window)


def actuator_peaks(acts: Any, tau: Any, dq: Any, u_safe: Any, env: Any,
                    dt: float) -> list[dict[str, Any]]:
    """Per actuator, what a run asked of it against its limits (SI; speeds in deg/s;
    the winding's temperature from 25 degC over the run, and the RMS motor current
    against the motor's nominal current: its continuous rating; the gear's transmitted
    torque, the delivered torque less the rotor's inertia torque N^2 J q'' (friction
    aside), against its momentary peak)."""
    from exoleg.device.thermal import winding_temperature

    out = []
    ddq = np.gradient(dq, dt, axis=0)
    for i, a in enumerate(acts):
        gear = np.abs(tau[:, i] - a.reflected_inertia * ddq[:, i])
        out.append({
            "joint": a.joint, "reflected_inertia_kg_m2": a.reflected_inertia,
            "peak_torque_Nm": float(np.abs(tau[:, i]).max()), "torque_limit_Nm": a.torque_limit,
            "rms_torque_Nm": float(np.sqrt(np.mean(tau[:, i] ** 2))),
            "continuous_torque_Nm": a.continuous_torque,
            "peak_speed_deg_s": float(np.degrees(np.abs(dq[:, i]).max())),
            "max_velocity_deg_s": float(np.degrees(a.max_velocity)),
            "peak_motor_speed_rpm": float(np.abs(dq[:, i]).max() * a.ratio * 30 / np.pi),
            "peak_power_W": float(np.abs(tau[:, i] * dq[:, i]).max()), "power_W": a.power,
            "ticks_at_envelope": int((np.abs(u_safe[:, i]) > env[:, i] + 1e-12).sum()),
            "rms_current_A": float(np.sqrt(np.mean((tau[:, i] / a.joint_torque_constant)
                                                   ** 2))),
            "nominal_current_A": a.nominal_current,
            "winding_max_C": float(winding_temperature(a, tau[:, i], dt)[:, 0].max()),
            "winding_limit_C": a.max_winding_temperature,
            "gear_peak_Nm": float(gear.max()), "momentary_peak_Nm": a.momentary_peak_torque,
            "ticks_over_momentary": int((gear > a.momentary_peak_torque).sum())})
    return out


def walk_peaks(r: WalkResult) -> list[dict[str, Any]]:
    """Per actuator, what a walk asked of it (:func:`actuator_peaks`), with the RMS
    tracking error after the first stride (deg) and what the safety layer saw: its
    hottest winding estimate (degC), its largest gear torque estimate (N m) and the ticks
    that estimate was beyond the gear's momentary peak."""
    from exoleg.control.safety import Limited

    walking = r.t >= r.walk_start + r.stride_time
    err = np.degrees(np.sqrt(np.mean((r.q - r.q_ref)[walking] ** 2, axis=0)))
    peaks = actuator_peaks(r.actuators, r.tau, r.dq, r.u_safe, r.envelope,
                           float(r.t[1] - r.t[0]))
    over = (r.safety_status & Limited.GEAR_PEAK) > 0
    for i, p in enumerate(peaks):
        gear = np.abs(r.gear_torque[:, i])
        p["rms_tracking_error_deg"] = float(err[i])
        p["safety_winding_max_C"] = float(r.winding_temp[:, i].max())
        p["safety_gear_peak_Nm"] = float(gear.max())
        p["safety_gear_overload_ticks"] = int((over & (gear > p["momentary_peak_Nm"])).sum())
    return peaks


def interaction_figures(values: Any, body_mass: float) -> list[dict[str, Any]]:
    """Per joint, the cuffs' torque ``values`` (n, 3) (N m; NaN where not measured):
    RMS and peak in N m and per kg of body mass, over the finite values (NaN if none)."""
    out = []
    for i, j in enumerate(JOINTS):
        v = np.asarray(values[:, i], dtype=float)
        v = v[np.isfinite(v)]
        rms = float(np.sqrt(np.mean(v * v))) if v.size else float("nan")
        peak = float(np.max(np.abs(v))) if v.size else float("nan")
        out.append({"joint": j, "rms_Nm": rms, "peak_Nm": peak,
                    "rms_Nm_per_kg": rms / body_mass, "peak_Nm_per_kg": peak / body_mass})
    return out


def interaction_summary(r: Any) -> list[dict[str, Any]]:
    """Per joint, the cuffs' torque while walking (from the walk's start to its end):
    :func:`interaction_figures`."""
    return interaction_figures(r.interaction[r.t >= r.walk_start], r.body_mass)


def support_per_stride(t: F64, level: F64, strikes: F64) -> F64:
    """The support level (``level`` (n, 3), 0-1 per joint and tick at times ``t``) per
    stride and joint, its mean over the stride's ticks: a row per stride between
    consecutive ``strikes`` (s, the initial contacts) that holds a tick."""
    rows = [level[(t >= a) & (t < b)] for a, b in zip(strikes[:-1], strikes[1:], strict=True)]
    return np.array([r.mean(axis=0) for r in rows if len(r)]).reshape(-1, 3)


def support_by_stride(t: F64, level: F64, strikes: F64) -> list[float]:
    """:func:`support_per_stride`'s mean over the joints: one value per stride."""
    return [float(x) for x in support_per_stride(t, level, strikes).mean(axis=1)]


def safety_events(t: F64, status: Any, since: float = -np.inf) -> list[dict[str, Any]]:
    """What the safety layer did from ``since`` s: per status bit that was set
    (:class:`~exoleg.control.safety.Limited`, the disarmed bit aside), when it first was
    (s), in how many ticks and its text; empty when it did nothing."""
    from exoleg.control.safety import LIMITED_TEXT, Limited

    sel = np.asarray(t) >= since
    st = np.asarray(status)[sel]
    ts = np.asarray(t)[sel]
    out = []
    for bit in Limited:
        if bit == Limited.DISARMED:
            continue
        hit = (st & int(bit)) != 0
        if hit.any():
            out.append({"event": bit.name.lower(), "text": LIMITED_TEXT[bit],
                        "first_s": float(ts[np.argmax(hit)]), "ticks": int(hit.sum())})
    return out
