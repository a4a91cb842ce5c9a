"""A sweep's summary drawn (``exoleg sweep``): per cell of its two axes, the fraction of
runs that walked (:func:`exoleg.study.summary.summarise`)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from exoleg.plots.figures import new_figure
from exoleg.study.summary import Summary


def heatmap(s: Summary, path: str | Path) -> Path:
    """The fraction of runs that walked per cell, coloured, with the runs and the share of
    ticks at a torque limit written in."""
    from exoleg.io import atomic_path

    img = np.full((len(s.ys), len(s.xs)), np.nan)
    fig = new_figure(max(4.0, 0.9 * len(s.xs) + 2), max(3.0, 0.5 * len(s.ys) + 1.6),
                     left=0.2, right=0.95, top=0.85, bottom=0.2)
    ax = fig.subplots()
    for (xv, yv), c in s.cells.items():
        i, j = s.ys.index(yv), s.xs.index(xv)
        img[i, j] = c["walked_fraction"]
        ax.text(j, i, f"{c['walked']}/{c['runs']}\n{c['clipped_fraction']:.2f}", ha="center",
                va="center", fontsize=7)
    im = ax.imshow(img, origin="lower", cmap="RdYlGn", vmin=0, vmax=1, aspect="auto")
    ax.set_xticks(range(len(s.xs)), [str(v) for v in s.xs], fontsize=7, rotation=30)
    ax.set_yticks(range(len(s.ys)), [str(v) for v in s.ys], fontsize=7)
    ax.set_xlabel(s.x, fontsize=8)
    ax.set_ylabel(s.y, fontsize=8)
    fig.colorbar(im, ax=ax, label="walked (no safety fault)")
    ax.set_title("runs walked / runs, and the share of ticks with a torque at its limit",
                 fontsize=8)
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=110, format="png")
    return Path(path)
