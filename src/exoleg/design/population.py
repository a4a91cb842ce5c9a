"""Population coverage: who the device fits, which limit binds, which actuator margin is smallest.

A grid of children -- ages x sex x group (GMFCS I-IV from Brooks 2011, typically
developing from WHO 2007) x height percentile -- each with the body mass of the same
percentile of its chart (an assumption: height and mass percentiles are not
independent in reality). Every child walks at one *gait* percentile (default the
median), independent of their growth percentile: a small child does not walk faster
for being small. For each child: dimensions (:mod:`anthropometry`), fit
(:mod:`fit`), personalized model (:mod:`personal`) and actuator margins
(:mod:`demand`), the simulated normative gait of all children run as one batch.
WHO 2007 has no weight beyond 10 years, so typically developing children older than
10 get the CDC 2000 mass percentile (stated in each row's notes).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np

from exoleg.design.demand import build_demand, device_limits, simulated_gait_peaks
from exoleg.device.actuator import paper_actuators, with_actuators
from exoleg.sizing.child import group_name, population_child
from exoleg.sizing.fit import device, fit_device
from exoleg.sizing.personal import personalized_leg

GROUPS: tuple[int | None, ...] = (1, 2, 3, 4, None)
PERCENTILES = (3.0, 10.0, 25.0, 50.0, 75.0, 90.0, 97.0)
AGES = (8.0, 9.0, 10.0, 11.0, 12.0)


@dataclass(frozen=True)
class Row:
    """One child of the grid and its verdict (lengths m, mass kg)."""

    age: float
    sex: str
    group: str
    percentile: float     # the growth charts' (height and mass)
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
    gait_percentile: float = 50.0  # the gait's demand (design.demand)


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
             speed: str = "Free", simulate: bool = True,
             actuators: tuple[Any, ...] | None = None,
             gait_percentile: float = 50.0) -> list[Row]:
    """The coverage grid against ``actuators`` (None: the shipped ones), every child's
    demand at ``gait_percentile`` (:func:`~exoleg.design.demand.build_demand`). With
    ``simulate`` each child's gait at that percentile is simulated (all children in one
    parallel batch) and counts among the demands."""
    from statistics import NormalDist

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
    acts = paper_actuators() if actuators is None else tuple(actuators)
    limits = device_limits(acts)
    peaks = None
    if simulate:  # one batch: every child, with the actuators' reflected inertia, follows
        # the mean gait of the speed group
        peaks = simulated_gait_peaks(np.stack([with_actuators(leg, acts).p for leg in legs]),
                                     legs[0].g, speed,
                                     NormalDist().inv_cdf(gait_percentile / 100.0),
                                     stride_time)
    rows = []
    for n, ((c, pct, group), f, leg) in enumerate(zip(children, fits, legs, strict=True)):
        dem = build_demand(c.mass, leg, gait_percentile, speed, stride_time,
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
                        notes=notes[n], gait_percentile=gait_percentile))
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
