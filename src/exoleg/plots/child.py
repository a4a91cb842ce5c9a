"""Figures of the simulated child: the clinical tests (``exoleg assess``) and a walk under
a support mode (``exoleg simulate --walk --child``)."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

from exoleg.plots.figures import _title, new_figure

if TYPE_CHECKING:
    from exoleg.child.assess import Pendulum, Stretch
    from exoleg.child.model import ChildModel
    from exoleg.sim.walk import WalkResult


def pendulum_figure(p: Pendulum, path: str | Path) -> Path:
    """The knee's angle and rate over the pendulum test, the peak marked."""
    from exoleg.io import atomic_path

    fig = new_figure(9, 4, left=0.08, right=0.98, top=0.9, bottom=0.13, wspace=0.3)
    a, b = fig.subplots(1, 2)
    a.plot(p.t, p.knee, lw=1)
    a.axhline(p.resting, color="0.6", lw=0.8, ls="--", label="resting angle")
    a.set_xlabel("time (s)")
    a.legend(fontsize=8)
    _title(a, "knee flexion (deg)")
    b.plot(p.t, p.rate, lw=1)
    b.plot([p.time_to_peak], [p.peak_velocity], "o", label=f"peak {p.peak_velocity:.0f} "
           f"deg/s at {p.time_to_peak:.2f} s")
    b.set_xlim(0, min(3.0, float(p.t[-1])))
    b.set_xlabel("time (s)")
    b.legend(fontsize=8)
    _title(b, "knee flexion rate (deg/s)")
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=100, format="png")
    return Path(path)


def stretch_figure(s: Stretch, path: str | Path) -> Path:
    """Resistance against knee flexion for each stretch speed, and its peak against
    speed."""
    from exoleg.io import atomic_path

    fig = new_figure(9, 4, left=0.08, right=0.98, top=0.9, bottom=0.13, wspace=0.3)
    a, b = fig.subplots(1, 2)
    for v, x, r in zip(s.speeds, s.angle, s.resistance, strict=True):
        a.plot(x, r, lw=1, label=f"{v:g} deg/s")
    if s.catch_angle is not None:
        a.axvline(s.catch_angle, color="r", lw=0.8, ls="--", label="catch (R1)")
    a.invert_xaxis()
    a.set_xlabel("knee flexion (deg), extending")
    a.legend(fontsize=7)
    _title(a, "resistance to stretch (N m)")
    b.plot(s.speeds, s.peak_resistance, "o-")
    b.set_xlabel("stretch speed (deg/s)")
    _title(b, "peak resistance (N m)")
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=100, format="png")
    return Path(path)


def support_figure(r: WalkResult, child: ChildModel, strikes: Any, path: str | Path) -> Path:
    """A walk with the child as an actor under a support mode: top, the cuffs' torque over
    the gait cycle per joint (every tick of every stride after the first, N m/kg);
    middle, the support per stride (each joint's mean over the stride, 0-1) and the
    child's stance share; bottom, each joint's angle over the cycle against the gait the
    child means (:func:`~exoleg.child.model.intended_gait`) and the device's reference."""
    import numpy as np

    from exoleg.child.model import intended_gait
    from exoleg.io import atomic_path
    from exoleg.params.records import JOINTS
    from exoleg.sim.metrics import support_per_stride
    from exoleg.tick import Mode

    fig = new_figure(12, 9.5, left=0.06, right=0.98, top=0.94, bottom=0.06, wspace=0.28,
                     hspace=0.45)
    axes = fig.subplots(3, 3)
    walking = (r.mode == Mode.WALKING) & (r.t > r.walk_start + r.stride_time)
    x = 100 * r.gait_fraction[walking]
    q_int, _, _ = intended_gait(child, r.stride_time)
    pct = np.linspace(0.0, 100.0, len(q_int))
    for i, j in enumerate(JOINTS):
        ax = axes[0, i]
        ax.plot(x, r.interaction[walking, i] / r.body_mass, ".", ms=0.6)
        ax.axhline(0.0, color="0.6", lw=0.6)
        _title(ax, f"{j}: the cuffs' torque (N m/kg) over the gait cycle (%)")
        ax = axes[2, i]
        ax.plot(x, np.degrees(r.q[walking, i]), ".", ms=0.6, label="walked")
        ax.plot(x, np.degrees(r.q_ref[walking, i]), ".", ms=0.3, color="0.25",
                label="the device's reference")
        ax.plot(pct, np.degrees(q_int[:, i]), "k--", lw=1, label="the child's intended gait")
        _title(ax, f"{j} angle (deg) over the gait cycle (%)")
        ax.legend(fontsize=6, loc="best")
    ax = axes[1, 0]
    per = support_per_stride(r.t, r.support_level, strikes)
    for i, j in enumerate(JOINTS):
        ax.plot(np.arange(1, len(per) + 1), per[:, i], "o-", ms=2, lw=0.8, label=j)
    ax.set_ylim(-0.05, 1.05)
    ax.set_xlabel("stride")
    ax.legend(fontsize=6)
    _title(ax, "support per stride (1: the impedance's, 0: transparent)")
    ax = axes[1, 1]
    ax.plot(r.t, r.child_share, lw=0.8)
    ax.set_xlabel("time (s)")
    _title(ax, "the child's stance share of the normative moments (a learning child's "
               "changes)")
    axes[1, 2].axis("off")
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=100, format=Path(path).suffix.lstrip(".") or "png")
    return Path(path)
