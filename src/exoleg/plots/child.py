"""Figures of the clinical tests on the simulated child (``exoleg assess``)."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

from exoleg.plots.figures import _title, new_figure

if TYPE_CHECKING:
    from exoleg.child.assess import Pendulum, Stretch


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
