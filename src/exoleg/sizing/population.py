"""Population coverage: who the device fits, which limit binds, which actuator margin is smallest.

A grid of children -- ages x sex x group (GMFCS I-IV from Brooks 2011, typically
developing from WHO 2007) x height percentile -- each with the body mass of the same
percentile of its chart (an assumption: height and mass percentiles are not
independent in reality). For each child: dimensions (:mod:`anthropometry`), fit
(:mod:`fit`), personalized model (:mod:`personal`) and actuator margins
(:mod:`demand`), the simulated normative gait of all children run as one batch.
WHO 2007 has no weight beyond 10 years, so typically developing children older than
10 get the CDC 2000 mass percentile (stated in each row's notes).
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np

from exoleg.device.actuator import paper_actuators, with_actuators
from exoleg.sizing import growth
from exoleg.sizing.child import Child, DesignRangeWarning
from exoleg.sizing.demand import build_demand, device_limits, simulated_gait_peaks
from exoleg.sizing.fit import device, fit_device
from exoleg.sizing.personal import personalized_leg

GROUPS: tuple[int | None, ...] = (1, 2, 3, 4, None)
PERCENTILES = (3.0, 10.0, 25.0, 50.0, 75.0, 90.0, 97.0)
AGES = (8.0, 9.0, 10.0, 11.0, 12.0)


def group_name(g: int | None) -> str:
    return "TD" if g is None else f"GMFCS {'I II III IV V'.split()[g - 1]}"


@dataclass(frozen=True)
class Row:
    """One child of the grid and its verdict (lengths m, mass kg)."""

    age: float
    sex: str
    group: str
    percentile: float
    height: float
    mass: float
    thigh: float
    shank: float
    foot_length: float
    fits: bool
    binding: str          # what misses, or the tightest telescope/footplate limit
    by_m: float           # by how much it misses (< 0 short, > 0 long), or the slack left
    paper_rule_fits: bool
    margin: float         # smallest actuator margin (limit / demand)
    margin_where: str     # source, quantity, joint of that margin
    within_limits: bool   # every demand within the device's limits (margin >= 1)
    exceeds: str          # the demands over them, "; "-separated ("" when none)
    exceeds_where: str    # their joint and quantity, ", "-separated ("ankle speed, ...")
    notes: str = ""


def _mass(group: int | None, sex: str, age: float, pct: float) -> tuple[float, str]:
    chart = growth.chart_for(group, "weight", age)
    note = "" if chart == growth.chart_for(group) else (
        f"mass from {chart} ({growth.chart_for(group)} has no weight at {age:g} y)")
    return growth.value_at(chart, sex, "weight", age, pct), note


def population_child(group: int | None, sex: str, age: float, pct: float) -> tuple[Child, str]:
    """The child of a growth chart: height and mass at the same percentile ``pct`` of its
    group's chart (GMFCS 1-4: Brooks 2011; None: WHO 2007, CDC 2000 where WHO has no row)
    at ``age``, and a note when the mass came from another chart."""
    h = growth.value_at(growth.chart_for(group), sex, "height", age, pct)
    m, note = _mass(group, sex, age, pct)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DesignRangeWarning)
        c = Child(age=age, sex=sex, height=h, mass=m, gmfcs=group,  # type: ignore[arg-type]
                  name=f"{group_name(group)} {sex} {age:g} y P{pct:g}")
    return c, note


def _binding(fit: Any) -> tuple[str, float]:
    if fit.misses:
        worst = max(fit.misses, key=lambda m: abs(m.by))
        return worst.what, worst.by
    dev = fit.dimensions
    d = device()
    slack = {"upper telescope (hip-knee)": min(dev.thigh - d["upper_range_m"][0],
                                               d["upper_range_m"][1] - dev.thigh),
             "lower telescope (knee-sole)": min(
                 dev.shank + dev.ankle_height - d["lower_range_m"][0],
                 d["lower_range_m"][1] - dev.shank - dev.ankle_height),
             "footplate (foot length)": d["footplate_length_m"] - dev.foot_length}
    k = min(slack, key=slack.__getitem__)
    return k, slack[k]


def coverage(ages: Sequence[float] = AGES, sexes: Sequence[str] = ("female", "male"),
             groups: Sequence[int | None] = GROUPS,
             percentiles: Sequence[float] = PERCENTILES, stride_time: float = 1.1,
             speed: str = "Free", simulate: bool = True) -> list[Row]:
    """The coverage grid. With ``simulate`` each child's normative gait is simulated
    (all children in one parallel batch) and counts among the demands."""
    children, fits, legs, notes = [], [], [], []
    for group in groups:
        for sex in sexes:
            for age in ages:
                for pct in percentiles:
                    c, note = population_child(group, sex, age, pct)
                    f = fit_device(c)
                    children.append((c, pct, group))
                    fits.append(f)
                    legs.append(personalized_leg(c, f))
                    notes.append(note)
    acts = paper_actuators()
    limits = device_limits(acts)
    peaks = None
    if simulate:  # one batch: every child, with the actuators' reflected inertia, follows
        # the mean gait of the speed group
        peaks = simulated_gait_peaks(np.stack([with_actuators(leg, acts).p for leg in legs]),
                                     legs[0].g, speed, 0.0, stride_time)
    rows = []
    for n, ((c, pct, group), f, leg) in enumerate(zip(children, fits, legs, strict=True)):
        dem = build_demand(c.mass, leg, pct, speed, stride_time,
                           None if peaks is None else peaks[n], grid=7, limits=limits)
        margin, src, qty, joint = dem.smallest_margin()
        over = dem.exceedances()
        what, by = _binding(f)
        rows.append(Row(age=c.age, sex=c.sex, group=group_name(group), percentile=pct,
                        height=c.height, mass=c.mass, thigh=f.dimensions.thigh,
                        shank=f.dimensions.shank, foot_length=f.dimensions.foot_length,
                        fits=f.fits, binding=what, by_m=by,
                        paper_rule_fits=bool(f.paper_rule["fits"]), margin=margin,
                        margin_where=f"{src}: {qty} at the {joint}",
                        within_limits=not over, exceeds="; ".join(map(str, over)),
                        exceeds_where=", ".join(dict.fromkeys(f"{e.joint} {e.quantity}"
                                                              for e in over)),
                        notes=notes[n]))
    return rows


def write_csv(rows: list[Row], path: str | Path) -> Path:
    """The coverage table as CSV (lengths m, mass kg)."""
    import csv

    from exoleg.io import atomic_path

    with atomic_path(path) as tmp, tmp.open("w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(asdict(rows[0])))
        w.writeheader()
        for r in rows:
            w.writerow(asdict(r))
    return Path(path)


def heatmap(rows: list[Row], path: str | Path) -> Path:
    """A heat map per group and sex: age x height percentile, coloured by the geometric
    fit and the actuators together -- too small a child, fits and every demand within
    Table 2, fits but a demand over Table 2, too large -- with the smallest actuator
    margin written in (a margin below 1 is a demand over its limit, marked "!")."""
    from matplotlib.colors import ListedColormap

    from exoleg.plots.figures import new_figure

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
