"""The figure of an identification on the device (``exoleg identify``)."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

from exoleg.params.records import JOINTS
from exoleg.plots.figures import _title, new_figure

if TYPE_CHECKING:
    from exoleg.identify.device import DeviceIdentification


def identify_figure(ident: DeviceIdentification, path: str | Path) -> Path:
    """Per joint, the drives' torque over the held-out period of the plan (measured, the
    child's passive moments at their model added) against the torque the identified leg
    predicts, and the error's RMS."""
    from exoleg.io import atomic_path

    m = ident.measured
    t = m.t[m.held_out]
    fig = new_figure(11, 3.6, left=0.06, right=0.99, top=0.84, bottom=0.14, wspace=0.25)
    for j, ax in enumerate(fig.subplots(1, 3)):
        ax.plot(t, m.tau[m.held_out, j], lw=1.2, color="0.3", label="measured")
        ax.plot(t, ident.predicted[m.held_out, j], lw=0.9, ls="--", color="C3",
                label="identified leg")
        ax.set_xlabel("time in the plan (s)")
        _title(ax, f"{JOINTS[j]} torque (N m)\nheld-out RMS error "
                   f"{ident.held_out_rms[j]:.2f} N m ({ident.held_out_pct[j]:.1f} %)")
        if j == 0:
            ax.legend(fontsize=8)
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=100, format="png")
    return Path(path)
