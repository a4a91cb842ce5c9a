"""The population's coverage drawn (``exoleg population``): who the device fits and whose
gait the actuators carry, by age and height percentile (:mod:`exoleg.design.population`)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from exoleg.design.population import Row
from exoleg.plots.figures import new_figure


def heatmap(rows: list[Row], path: str | Path) -> Path:
    """A heat map per group and sex: age x height percentile, coloured by the geometric
    fit and the actuators together -- too small a child, fits and every demand within
    Table 2, fits but a demand over Table 2, too large -- with the smallest actuator
    margin written in (a margin below 1 is a demand over its limit, marked "!")."""
    from matplotlib.colors import ListedColormap

    groups = list(dict.fromkeys(r.group for r in rows))
    sexes = list(dict.fromkeys(r.sex for r in rows))
    ages = sorted({r.age for r in rows})
    pcts = sorted({r.percentile for r in rows})
    fig = new_figure(3.2 * len(groups), 3.4 * len(sexes), left=0.05, right=0.99, top=0.88,
                     bottom=0.1, wspace=0.3, hspace=0.4)
    axes = fig.subplots(len(sexes), len(groups), squeeze=False)
    cmap = ListedColormap(["#d95f02", "#1b9e77", "#e6ab02", "#7570b3"])
    for si, sex in enumerate(sexes):
        for gi, grp in enumerate(groups):
            ax = axes[si, gi]
            img = np.full((len(pcts), len(ages)), np.nan)
            for r in rows:
                if r.sex == sex and r.group == grp:
                    i, j = pcts.index(r.percentile), ages.index(r.age)
                    img[i, j] = ((1 if r.within_limits else 2) if r.fits
                                 else (0 if r.by_m < 0 else 3))
                    ax.text(j, i, f"{r.margin:.2f}" + ("" if r.margin >= 1 else "!"),
                            ha="center", va="center", fontsize=6)
            ax.imshow(img, origin="lower", cmap=cmap, vmin=0, vmax=3, aspect="auto")
            ax.set_xticks(range(len(ages)), [f"{a:g}" for a in ages], fontsize=7)
            ax.set_yticks(range(len(pcts)), [f"P{p:g}" for p in pcts], fontsize=7)
            ax.set_title(f"{grp}, {sex}", fontsize=8)
            if si == len(sexes) - 1:
                ax.set_xlabel("age (years)", fontsize=7)
    fig.suptitle("orange: child too small for the device; green: fits, every demand within "
                 "the actuators' limits (datasheets); yellow: fits, but a demand exceeds them; "
                 "purple: child too large\n"
                 "numbers: smallest actuator margin (limit / demand; ! = below 1, over the limit)",
                 fontsize=8)
    from exoleg.io import atomic_path

    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=110, format=Path(path).suffix.lstrip(".") or "png")
    return Path(path)
