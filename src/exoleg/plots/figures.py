"""The paper's Figs 13-15 drawn from a :class:`~exoleg.sim.scenario.ScenarioReport`.

Fig. 13: A-C joint angles (reference, exoleg, engine), D abs(detailed - simplified),
E abs(exoleg - engine), F abs(reference - exoleg), all in degrees, errors on log axes.
Error panels show the largest abs(error) per time bin (an envelope). Fig. 14: the
verification signal dq^T (Mdot - 2C) dq. Fig. 15: control torques.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from matplotlib.ticker import LogFormatter, NullLocator

from exoleg.params.records import JOINTS
from exoleg.sim.scenario import ScenarioReport

if TYPE_CHECKING:
    from exoleg.device.actuator import ActuatorModel
    from exoleg.sim.device_loop import DeviceResult
    from exoleg.sim.walk import WalkResult

_BINS = 600  # points drawn per curve


def _envelope(t: np.ndarray, err: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Largest |err| in each of about _BINS time bins (exact zeros, which a log axis
    cannot show, become gaps)."""
    n = max(1, len(t) // _BINS)
    m = len(t) // n * n
    tb = t[:m].reshape(-1, n).mean(axis=1)
    eb = np.abs(err[:m]).reshape(-1, n, err.shape[1]).max(axis=1)
    return tb, np.where(eb > 0, eb, np.nan)


def _thin(t: np.ndarray, *ys: np.ndarray) -> tuple[np.ndarray, ...]:
    """Every k-th sample so a curve has at most about 3 * _BINS points (smooth curves)."""
    k = max(1, len(t) // (3 * _BINS))
    return (t[::k], *(y[::k] for y in ys))


def new_figure(width: float, height: float, **margins: float) -> Figure:
    """A figure without pyplot (no global state, nothing to close; it renders with Agg
    when saved), with fixed margins (no layout engine to run at draw time)."""
    fig = Figure(figsize=(width, height))
    fig.subplots_adjust(**margins)
    return fig


def _title(ax: Axes, text: str) -> None:
    # an explicit y: otherwise every draw measures the tick labels to place the title
    ax.set_title(text, fontsize=9, y=1.0)


def _log_error(ax: Axes, t: np.ndarray, err: np.ndarray, title: str) -> None:
    tb, eb = _envelope(t, err)
    for i, j in enumerate(JOINTS):
        ax.semilogy(tb, eb[:, i], lw=0.8, label=j)
    # "1e-14" as plain text (no mathtext to parse) and no minor ticks: drawing the ticks
    # was most of the figure's cost
    ax.yaxis.set_major_formatter(LogFormatter())
    ax.yaxis.set_minor_locator(NullLocator())
    _title(ax, title)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("error (deg)")
    ax.legend(fontsize=7)


def fig13(report: ScenarioReport) -> Figure:
    """Paper Fig. 13 A-F.

    Parameters
    ----------
    report : ScenarioReport
        The run and its figures (:func:`exoleg.sim.scenario.run_scenario`).

    Returns
    -------
    matplotlib.figure.Figure
    """
    r = report.result
    fig = new_figure(13, 7, left=0.06, right=0.98, top=0.95, bottom=0.08, wspace=0.28,
                     hspace=0.35)
    axes = fig.subplots(2, 3)
    eq = report.engine_q if report.engine_q is not None else r.q
    t, qr, q, qe = _thin(r.t, np.degrees(r.q_ref), np.degrees(r.q), np.degrees(eq))
    for i, j in enumerate(JOINTS):
        ax = axes[0, i]
        ax.plot(t, qr[:, i], "k--", lw=1, label="reference")
        ax.plot(t, q[:, i], lw=1.2, label="exoleg")
        if report.engine_q is not None:
            ax.plot(t, qe[:, i], ":", lw=1.5, label=report.engine_name)
        _title(ax, f"({'ABC'[i]}) {j} position")
        ax.set_xlabel("time (s)")
        ax.set_ylabel("angle (deg)")
        ax.legend(fontsize=7)
    if report.detailed is not None:
        _log_error(axes[1, 0], r.t, np.degrees(report.detailed.q - r.q),
                   "(D) detailed (2x torque) - simplified")
    else:
        axes[1, 0].set_axis_off()
    if report.engine_q is not None:
        _log_error(axes[1, 1], r.t, np.degrees(report.engine_q - r.q),
                   f"(E) {report.engine_name} - exoleg")
    else:
        axes[1, 1].set_axis_off()
    _log_error(axes[1, 2], r.t, np.degrees(r.error), "(F) reference - exoleg")
    return fig


def fig14(report: ScenarioReport) -> Figure:
    """Paper Fig. 14: the verification signal.

    Parameters
    ----------
    report : ScenarioReport
        The run and its figures (:func:`exoleg.sim.scenario.run_scenario`).

    Returns
    -------
    matplotlib.figure.Figure
    """
    r = report.result
    fig = new_figure(7, 3.5, left=0.14, right=0.97, top=0.9, bottom=0.14)
    ax = fig.subplots()
    tb, vb = _envelope(r.t, r.verification[:, None])
    ax.plot(tb, vb[:, 0], lw=0.8, label="max |signal| per bin")
    ax.legend(fontsize=7)
    _title(ax, "verification signal  dq^T (Mdot - 2C) dq")
    ax.set_xlabel("time (s)")
    ax.set_ylabel("W")
    return fig


def fig15(report: ScenarioReport) -> Figure:
    """Paper Fig. 15: control torques (non-zero at rest: G(q)).

    Parameters
    ----------
    report : ScenarioReport
        The run and its figures (:func:`exoleg.sim.scenario.run_scenario`).

    Returns
    -------
    matplotlib.figure.Figure
    """
    r = report.result
    fig = new_figure(7, 3.5, left=0.12, right=0.97, top=0.9, bottom=0.14)
    ax = fig.subplots()
    t, u = _thin(r.t, r.u)
    for i, j in enumerate(JOINTS):
        ax.plot(t, u[:, i], lw=1, label=j)
    _title(ax, "control torques")
    ax.set_xlabel("time (s)")
    ax.set_ylabel("torque (N m)")
    ax.legend(fontsize=7)
    return fig


def save_figures(report: ScenarioReport, folder: str | Path,
                 formats: tuple[str, ...] = ("png",)) -> list[Path]:
    """Write Figs 13, 14 and 15 in each format.

    Parameters
    ----------
    report : ScenarioReport
        The run and its figures (:func:`exoleg.sim.scenario.run_scenario`).
    folder : str or Path
        Where (made if missing).
    formats : tuple of str, default ("png",)
        File formats (png, svg, pdf).

    Returns
    -------
    list of Path
        The files written.
    """
    out = Path(folder)
    out.mkdir(parents=True, exist_ok=True)
    paths = []
    for name, make in (("fig13", fig13), ("fig14", fig14), ("fig15", fig15)):
        fig = make(report)
        for fmt in formats:
            p = out / f"{name}.{fmt}"
            # PNG: light compression (the default level takes longer than drawing)
            if fmt == "png":  # (print_svg takes no pil_kwargs)
                fig.savefig(p, dpi=120, format=fmt, pil_kwargs={"compress_level": 1})
            else:
                fig.savefig(p, dpi=120, format=fmt)
            paths.append(p)
    return paths


def _torque_speed(ax: Axes, actuator: ActuatorModel, t: np.ndarray, dq: np.ndarray,
                  tau: np.ndarray) -> None:
    """One joint's delivered torque against its speed over the actuator's envelope, with
    the fastest the actuator turns at its bus voltage marked."""
    from exoleg.device.drive import envelope

    par = actuator.record()
    w = np.linspace(0, 1.15 * actuator.max_velocity, 400)
    env = np.array([envelope(par, x) for x in w])
    wd = np.degrees(w)
    ax.fill_between(wd, -env, env, color="0.9", label="envelope")
    ax.fill_between(-wd, -env, env, color="0.9")
    _, v, tq = _thin(t, np.degrees(dq), tau)
    ax.plot(v, tq, ".", ms=1.2, label="delivered")
    vmax = np.degrees(actuator.max_velocity)
    ax.axvline(vmax, color="r", lw=0.6, ls=":")
    ax.axvline(-vmax, color="r", lw=0.6, ls=":", label="max velocity (bus voltage)")
    _title(ax, f"{actuator.joint}: torque (N m) vs speed (deg/s)")
    ax.legend(fontsize=6, loc="lower left")


def device_figure(result: DeviceResult, path: str | Path) -> Path:
    """A device run (:func:`exoleg.sim.device_loop.simulate_device`): top, each joint's
    angle against its reference (deg); bottom, its torque-speed plane -- the drive's
    delivered torque against the joint speed, over the actuator's envelope (Table 2's
    peak torque, rated power, maximum velocity)."""
    fig = new_figure(11, 6.5, left=0.07, right=0.98, top=0.89, bottom=0.08, wspace=0.28,
                     hspace=0.35)
    axes = fig.subplots(2, 3)
    r = result
    t, q, qr = _thin(r.t, np.degrees(r.q), np.degrees(r.q_ref))
    for i, j in enumerate(JOINTS):
        ax = axes[0, i]
        ax.plot(t, qr[:, i], "k--", lw=0.8, label="reference")
        ax.plot(t, q[:, i], lw=1.0, label="device")
        _title(ax, f"{j} angle (deg)")
        ax.set_xlabel("t (s)", fontsize=8)
        ax.legend(fontsize=7, loc="best")
        _torque_speed(axes[1, i], r.actuators[i], r.t, r.dq[:, i], r.tau[:, i])
    fig.suptitle(f"device run: actuators, encoders, safety layer"
                 f"{' -- FAULT ' + r.fault if r.fault else ''}", fontsize=10)
    from exoleg.io import atomic_path

    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=110, format=Path(path).suffix.lstrip(".") or "png")
    return Path(path)


def walk_figure(result: WalkResult, path: str | Path) -> Path:
    """A walking run (:func:`exoleg.sim.walk.simulate_walk`): top, each joint's angle over
    the detected gait cycle, every stride, on the normative band (Schwartz 2008, mean
    +- 1 SD); middle, the last three strides' FSR readings, the detected phase against
    the true contacts, the foot gyroscope; bottom, each joint's delivered torque against
    its speed over the actuator's envelope."""
    from exoleg.control.gait_phase import Phase
    from exoleg.reference.gait import gait_angles
    from exoleg.tick import SENSOR_POINTS, Mode

    r = result
    fig = new_figure(12, 9.5, left=0.06, right=0.98, top=0.94, bottom=0.06, wspace=0.28,
                     hspace=0.45)
    axes = fig.subplots(3, 3)
    walking = (r.mode == Mode.WALKING) & (r.t > r.walk_start + r.stride_time)
    pct, mean = gait_angles("Free", 0.0)
    lo, hi = gait_angles("Free", -1.0)[1], gait_angles("Free", 1.0)[1]
    x = 100 * r.gait_fraction[walking]
    for i, j in enumerate(JOINTS):
        ax = axes[0, i]
        ax.fill_between(pct, np.degrees(np.minimum(lo[:, i], hi[:, i])),
                        np.degrees(np.maximum(lo[:, i], hi[:, i])), color="0.85",
                        label="normative +- 1 SD")
        ax.plot(pct, np.degrees(mean[:, i]), "k--", lw=0.8, label="normative mean")
        ax.plot(x, np.degrees(r.q[walking, i]), ".", ms=0.8, label="device")
        _title(ax, f"{j} angle (deg) over the gait cycle (%)")
        ax.legend(fontsize=6, loc="best")
    last = r.t >= r.t[-1] - 3 * r.stride_time
    t = r.t[last]
    ax = axes[1, 0]
    for k, s in enumerate(SENSOR_POINTS):
        ax.plot(t, r.fsr[last, k], lw=0.7, label=s)
    _title(ax, "FSR readings (ADC counts)")
    ax.legend(fontsize=6, loc="upper right")
    ax = axes[1, 1]
    ax.step(t, r.phase[last], where="post", lw=0.9, label="detected phase")
    true_contact = (r.contact_force[last].sum(axis=1) > 5.0).astype(float)
    ax.fill_between(t, -1.2, -1.2 + true_contact, step="post", color="C1", alpha=0.4,
                    label="true contact")
    ax.set_yticks([int(p) for p in Phase],
                  ["" if p == Phase.UNKNOWN else p.name.lower() for p in Phase], fontsize=7)
    _title(ax, "gait phase: detected vs true contact")
    ax.legend(fontsize=6, loc="upper right")
    ax = axes[1, 2]
    ax.plot(t, np.degrees(r.gyro[last]), lw=0.7)
    _title(ax, "foot gyroscope (deg/s)")
    for i in range(3):
        _torque_speed(axes[2, i], r.actuators[i], r.t, r.dq[:, i], r.tau[:, i])
    fig.suptitle("walking with the device: actuators, sensors, gait phases, control hierarchy, "
                 "safety layer", fontsize=10)
    from exoleg.io import atomic_path

    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=100, format=Path(path).suffix.lstrip(".") or "png")
    return Path(path)


def session_figure(log_path: str | Path, path: str | Path) -> Path:
    """A recorded session (``exoleg run``, the operator interface): top, each joint's
    measured angle (deg) with the supervisor's mode shaded; middle, each joint's commanded
    torque against its speed over the actuator's envelope; bottom, the FSR readings, the
    detected gait phase, and the loop's lateness per tick."""
    from exoleg.control.gait_phase import Phase
    from exoleg.device.actuator import paper_actuators
    from exoleg.io import atomic_path
    from exoleg.session_log import read_log
    from exoleg.tick import Mode

    header, c, _ = read_log(log_path)
    t = c["t"]
    fig = new_figure(12, 9, left=0.06, right=0.98, top=0.93, bottom=0.06, wspace=0.28,
                     hspace=0.45)
    axes = fig.subplots(3, 3)
    mode = c["mode"]
    shades = {Mode.STANDING: "C2", Mode.WALKING: "C0", Mode.STOPPING: "C1", Mode.FAULT: "C3"}
    acts = paper_actuators()
    for i, j in enumerate(JOINTS):
        ax = axes[0, i]
        tt, q = _thin(t, np.degrees(c[f"q_meas_{j}"]))
        ax.plot(tt, q, lw=0.9, color="k")
        for m, color in shades.items():
            on = (mode == m).astype(float)
            if on.any():
                ax.fill_between(t, 0, 1, where=on > 0, transform=ax.get_xaxis_transform(),
                                color=color, alpha=0.12, lw=0, label=m.name.lower())
        _title(ax, f"{j} angle (deg); shading: mode")
        ax.set_xlabel("t (s)", fontsize=8)
        ax.legend(fontsize=6, loc="best")
        _torque_speed(axes[1, i], acts[i], t, c[f"dq_meas_{j}"], c[f"u_{j}"])
    ax = axes[2, 0]
    fsr = [k for k in c if k.startswith("fsr_")]
    for k in fsr:
        ax.plot(*_thin(t, c[k]), lw=0.6, label=k[4:])
    _title(ax, "FSR readings (ADC counts)")
    ax.legend(fontsize=6, loc="upper right")
    ax = axes[2, 1]
    ax.step(*_thin(t, c["phase"]), where="post", lw=0.8)
    ax.set_yticks([int(p) for p in Phase], [p.name.lower() for p in Phase], fontsize=7)
    _title(ax, "detected gait phase")
    ax = axes[2, 2]
    ax.plot(*_thin(t, c["late"] * 1e6), lw=0.6)
    period = float(header.get("period", 1e-3))
    ax.axhline(period * 1e6, color="r", lw=0.6, ls=":", label="one period")
    ax.set_yscale("symlog", linthresh=10.0)
    _title(ax, "loop lateness per tick (us)")
    ax.legend(fontsize=6)
    fig.suptitle(f"session {Path(log_path).parent.name}: {header.get('backend', '?')} "
                 f"backend, {len(t) * period:.1f} s, leg {header.get('leg', '?')}",
                 fontsize=10)
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=90, format="png")
    return Path(path)
