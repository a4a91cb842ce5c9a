"""Figures in the paper's style (Figs 13-15) and a gait animation (Fig. 16 / Video S1)."""

from exoleg.plots.animation import animate
from exoleg.plots.figures import fig13, fig14, fig15, save_figures

__all__ = ["animate", "fig13", "fig14", "fig15", "save_figures"]
