"""``exoleg simulate --actuators``: the run through the device's actuators, encoders and
safety layer, against Table 2."""

from __future__ import annotations

import argparse
import dataclasses
import time
from typing import Any

from exoleg.cli._common import _say, _table
from exoleg.cli._runs import device_actuators, write_run


def _simulate_device(args: argparse.Namespace, cfg: dict[str, Any]) -> int:
    """``simulate --actuators``: the run through the device's actuators, encoders and
    safety layer (:func:`exoleg.sim.device_loop.simulate_device`), against Table 2."""
    import numpy as np

    from exoleg.control.safety import Limited
    from exoleg.errors import ParameterError
    from exoleg.plots.figures import device_figure
    from exoleg.sim.device_loop import simulate_device
    from exoleg.sim.metrics import actuator_peaks

    t0 = time.perf_counter()
    control_dt = 1.0 / args.control_rate
    substeps = int(round(control_dt / args.dt))
    if substeps < 1 or abs(substeps * args.dt - control_dt) > 1e-9 * control_dt:
        raise ParameterError("exoleg simulate", "--dt", f"{args.dt:g} s must divide the "
                             f"control period {control_dt:g} s with --actuators")
    r = simulate_device(cfg["leg"], cfg["controller"], cfg["reference"], args.duration,
                        control_dt=control_dt, substeps=substeps, q0=cfg["q0"],
                        device=args.device, actuators=device_actuators(args))
    ideal = None
    if not args.no_engine:  # the same run with ideal torques, for the comparison
        from exoleg import simulate

        ideal = simulate(cfg["leg"], cfg["controller"], cfg["reference"], args.duration,
                         dt=control_dt, q0=cfg["q0"])
    acts = r.actuators
    peaks = actuator_peaks(acts, r.tau, r.dq, r.u_safe, r.envelope, control_dt)
    rows = []
    for i, (a, peak) in enumerate(zip(acts, peaks, strict=True)):
        peak["peak_command_Nm"] = float(np.abs(r.u_command[:, i]).max())
        rows.append([a.joint, f"{a.reflected_inertia:.3g}",
                     f"{peak['peak_command_Nm']:.1f} / {peak['peak_torque_Nm']:.1f} / "
                     f"{a.torque_limit:.0f}",
                     f"{peak['rms_torque_Nm']:.1f} / {a.continuous_torque:.0f}",
                     f"{peak['peak_speed_deg_s']:.0f} / {peak['max_velocity_deg_s']:.0f}",
                     f"{peak['rms_current_A']:.2f} / {a.nominal_current:g}",
                     f"{peak['winding_max_C']:.1f} / {a.max_winding_temperature:g}",
                     f"{peak['gear_peak_Nm']:.0f} / {a.momentary_peak_torque:g}",
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
        "safety_ticks_rate_limited": int(((r.status & Limited.RATE) > 0).sum()),
        "safety_ticks_torque_clipped": int(((r.status & Limited.TORQUE) > 0).sum()),
        "safety_ticks_gear_limited": int(((r.status & Limited.GEAR) > 0).sum()),
        "safety_ticks_soft_limit": int(((r.status & Limited.SOFT_LIMIT) > 0).sum()),
        "safety_ticks_derated": int(((r.status & Limited.DERATED) > 0).sum()),
        "safety_ticks_gear_beyond_momentary_peak": int(((r.status & Limited.GEAR_PEAK) > 0)
                                                       .sum()),
        "peaks": peaks,
    }
    wrote = write_run(args, r, device_figure, "actuators", t0,
                       {"leg": cfg["leg"].name, "figures": figs, "notes": cfg["warnings"],
                        "actuators": [dataclasses.asdict(a) for a in acts]})
    _say(f"exoleg simulate --actuators: {args.reference} reference, {args.controller} "
         f"controller, {args.duration:g} s, control {args.control_rate:g} Hz, "
         f"{substeps} plant step(s) per tick, leg '{cfg['leg'].name}' with the device's "
         f"actuators (hip: {acts[0].motor}; reflected inertia, friction, envelope, current "
         "loop), 20-bit encoders and the safety layer")
    _table(rows, ["joint", "armature kg m^2", "torque command / delivered / limit N m",
                  "RMS / continuous N m", "speed / at the bus deg/s",
                  "RMS current / motor's I_N A", "winding max / limit degC",
                  "gear peak / momentary N m", "ticks at envelope"])
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
                ["ticks derated (hot motor) / gear beyond its momentary peak",
                 f"{figs['safety_ticks_derated']} / "
                 f"{figs['safety_ticks_gear_beyond_momentary_peak']}", "-"],
                ["safety fault", r.fault or "none", "-"]]
    _table(fig_rows, ["figure", "with the actuators", "ideal torques"])
    if status & Limited.FAULT:
        _say(f"note: the safety layer stopped the run: {r.fault}; torque was off from then on")
    _say("note: the actuators' figures are the motors', gears' and EPOS4's sheets "
         "(device-datasheets.md; every figure and its source in summary.json, actuators); "
         "the limit is the gear's repeated peak or the drive's current limit, the speed the "
         "bus voltage's")
    _say(wrote)
    return 0
