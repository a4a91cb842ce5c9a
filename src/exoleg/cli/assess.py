"""``exoleg assess``: clinical tests on the simulated child (:mod:`exoleg.child.assess`)."""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

from exoleg.cli._common import _say, _table


def cmd_assess(args: argparse.Namespace) -> int:
    import warnings

    from exoleg.child.assess import pendulum, stretch
    from exoleg.child.model import ChildModel
    from exoleg.io import OutputFolder
    from exoleg.plots.child import pendulum_figure, stretch_figure
    from exoleg.sizing.child import DesignRangeWarning

    child = ChildModel.load(args.child)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DesignRangeWarning)  # a clinical test, not a fit
        result: Any = pendulum(child) if args.test == "pendulum" else stretch(child)
    summary = {"test": args.test, "child": child.name, "gmfcs": child.gmfcs,
               "spasticity": child.spasticity.level, "contracture": child.contracture.name,
               "contracture_level": child.contracture.level, **result.summary()}
    with OutputFolder(args.out, owner="exoleg assess",
                      will_write=("summary.json", f"{args.test}.png")) as out:
        if args.test == "pendulum":
            pendulum_figure(result, out.stage("pendulum.png"))
            figure = "pendulum.png"
        else:
            stretch_figure(result, out.stage("stretch.png"))
            figure = "stretch.png"
        out.stage("summary.json").write_text(json.dumps(summary, indent=2))
        out.commit(last="summary.json")
    _say(f"exoleg assess --test {args.test}: '{child.name}', {child.age:g} y, "
         f"{child.height * 100:.0f} cm, {child.mass:g} kg, "
         f"{'GMFCS ' + str(child.gmfcs) if child.gmfcs else 'TD'}, spasticity "
         f"{child.spasticity.level}, contracture {child.contracture.name}")
    if args.test == "pendulum":
        _table([["peak knee velocity", f"{result.peak_velocity:.0f} deg/s", "TD 293, CP 202"],
                ["time to peak", f"{result.time_to_peak:.3f} s", "TD 0.34, CP 0.22"],
                ["first swing", f"{result.first_swing:.1f} deg", ""],
                ["resting angle", f"{result.resting:.1f} deg", ""],
                ["relaxation index A1/A0", f"{result.relaxation_index:.2f}",
                 "below 1.6: spastic (Bajd & Vodovnik)"]],
               ["figure", "simulated", "published (White et al. 2007; 13 y)"])
    else:
        _table([[f"{v:g}", f"{p:.1f}"] for v, p in zip(result.speeds, result.peak_resistance,
                                                        strict=True)],
               ["stretch speed deg/s", "peak resistance N m"])
        catch = "none" if result.catch_angle is None else f"{result.catch_angle:.1f} deg"
        _say(f"catch angle (R1): {catch}; slow stretch's end of range (R2, 10 N m): "
             f"{result.end_of_range:.1f} deg knee flexion")
    _say(f"wrote {out.folder}/: summary.json, {figure}")
    return 0


def add_parser(sub: Any) -> None:
    """Add ``exoleg assess`` to the subcommands ``sub``."""
    a = sub.add_parser("assess", help="clinical tests on the simulated child: the pendulum "
                       "(Wartenberg) test, an instrumented knee stretch")
    a.add_argument("--child", type=Path, required=True, help="child.toml (exoleg fit)")
    a.add_argument("--test", choices=["pendulum", "stretch"], required=True)
    a.add_argument("--out", type=Path, default=Path("exoleg-assess"))
    a.set_defaults(func=cmd_assess)
