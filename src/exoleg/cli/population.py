"""``exoleg population``: the device's coverage over ages, sex, GMFCS levels and height
percentiles."""

from __future__ import annotations

import argparse
import time
from pathlib import Path
from typing import Any

from exoleg.cli._common import (
    STRIDE_TIME_RANGE,
    _ages,
    _device_option,
    _percentile,
    _percentiles,
    _say,
    _table,
    _within,
)


def cmd_population(args: argparse.Namespace) -> int:
    import collections

    from exoleg.design.population import PERCENTILES, coverage, write_csv
    from exoleg.device.actuator import paper_actuators
    from exoleg.io import OutputFolder
    from exoleg.plots.population import heatmap

    t0 = time.perf_counter()
    rows = coverage(ages=args.ages, percentiles=args.percentiles or PERCENTILES,
                    stride_time=args.stride_time, simulate=not args.no_simulate,
                    actuators=None if args.device is None else paper_actuators(args.device),
                    gait_percentile=args.gait_percentile)
    with OutputFolder(args.out, owner="exoleg population") as out:
        write_csv(rows, out.stage("coverage.csv"))
        heatmap(rows, out.stage("coverage.png"))
        out.commit()
    groups = list(dict.fromkeys(r.group for r in rows))
    table = []
    for g in groups:
        for sex in ("female", "male"):
            sel = [r for r in rows if r.group == g and r.sex == sex]
            if not sel:
                continue
            miss = collections.Counter(r.binding for r in sel if not r.fits)
            worst = min(sel, key=lambda r: r.margin)
            table.append([g, sex, f"{sum(r.fits for r in sel)}/{len(sel)}",
                          f"{sum(r.fits and r.within_limits for r in sel)}/{len(sel)}",
                          f"{sum(r.paper_rule_fits for r in sel)}/{len(sel)}",
                          "; ".join(f"{k} x{v}" for k, v in miss.items()) or "-",
                          f"{worst.margin:.2f} ({worst.margin_where})"])
    _table(table, ["group", "sex", "fits (geometry)", "fits, demand within the device's limits",
                   "paper rule fits", "misses (binding limit)", "smallest actuator margin"])
    over = collections.Counter(w for r in rows for w in r.exceeds_where.split(", ") if w)
    if over:
        _say("demands over the device's limits (children, by joint and quantity): "
             + ", ".join(f"{k} x{v}" for k, v in over.most_common()))
    _say("\nthe paper's design range (50th percentile):")
    for grp, sex, age in (("GMFCS IV", "female", 8.0), ("GMFCS I", "male", 12.0)):
        r = [x for x in rows if x.group == grp and x.sex == sex and x.age == age
             and x.percentile == 50.0]
        if r:
            x = r[0]
            _say(f"  {grp} {sex} {age:g} y: {x.height * 100:.1f} cm -> "
                 f"{'fits' if x.fits else 'does not fit'} ({x.binding}, "
                 f"{x.by_m * 100:+.1f} cm); paper rule: {'fits' if x.paper_rule_fits else 'no'}")
    _say(f"\nwrote {out.folder}/coverage.csv and coverage.png ({time.perf_counter() - t0:.1f} s)")
    return 0


def add_parser(sub: Any) -> None:
    """Add ``exoleg population`` to the subcommands ``sub``."""
    pop = sub.add_parser("population", help="device coverage over ages 8-12, sex, GMFCS I-IV "
                         "and TD, height percentiles")
    pop.add_argument("--ages", type=_ages, default=[8.0, 9.0, 10.0, 11.0, 12.0])
    pop.add_argument("--percentiles", type=_percentiles, help="the growth charts' height "
                     "(and mass) percentiles of the grid's children")
    pop.add_argument("--gait-percentile", type=_percentile, default=50.0,
                     help="the gait every child's demand is taken at (default 50: the "
                     "median; independent of their growth percentile)")
    pop.add_argument("--stride-time", type=_within(*STRIDE_TIME_RANGE, " s"), default=1.1)
    pop.add_argument("--no-simulate", action="store_true")
    pop.add_argument("--out", type=Path, default=Path("exoleg-population"))
    _device_option(pop, "the actuators every child's demand is judged against")
    pop.set_defaults(func=cmd_population)
