"""``exoleg design``: the actuation chosen for a population (:mod:`exoleg.design.study`)."""

from __future__ import annotations

import argparse
import math
import time
from pathlib import Path
from typing import Any

from exoleg.cli._common import _count, _say, _table


def cmd_design(args: argparse.Namespace) -> int:
    import csv

    from exoleg.design import verify as population
    from exoleg.design.study import Design, run_design, verify
    from exoleg.errors import ParameterError
    from exoleg.io import OutputFolder, refuse_overwrite, write_json

    t0 = time.perf_counter()
    if args.scheduler and args.workers:
        raise ParameterError("exoleg design", "--workers", "sizes the local cluster: not "
                             "with --scheduler (the cluster has its own workers)")
    design = Design.load(args.config)
    out = Path(args.out)
    actuators = out / "device" / "actuators"
    files = ("hip.toml", "knee.toml", "ankle.toml")
    # before the screen and the walks: none of the user's files is written over
    refuse_overwrite(out, "exoleg design", ("screen.csv", "verify.csv", "design.json",
                                            "verify-population.csv"))
    refuse_overwrite(actuators, "exoleg design", files)
    refuse_overwrite(out / "device", "exoleg design", ("transparency.toml", "assist.toml",
                                                       "walking_control.toml"))
    found = run_design(design)
    rows = found["rows"]
    with OutputFolder(actuators, owner="exoleg design") as dev:
        for j, text in found["text"].items():
            dev.stage(f"{j}.toml").write_text(text)
        dev.commit()
    with OutputFolder(out / "device", owner="exoleg design") as dev:
        dev.stage("transparency.toml").write_text(population.transparency_text(found["units"]))
        dev.stage("assist.toml").write_text(population.assist_text(design.alpha))
        dev.stage("walking_control.toml").write_text(
            population.walking_control_text(found["units"]))
        dev.commit()
    checked = verify(design, None) + verify(design, out / "device")
    floors = transparency_floors(design, out / "device", rows if args.bounds else None)
    served: list[dict[str, Any]] = []
    if not args.no_population:
        _say(f"exoleg design: verifying the device in the walking loop over the population "
             f"on the sweep engine ({out}/verify-transparent, verify-aan; resumable)")
        served = population.run(design, out / "device", out, args.scheduler, args.workers)
    with OutputFolder(out, owner="exoleg design") as o:
        keys = [k for k in rows[0] if not k.startswith("_")]
        with o.stage("screen.csv").open("w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=keys)
            w.writeheader()
            for r in rows:
                w.writerow({k: r[k] for k in keys})
        with o.stage("verify.csv").open("w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=list(checked[0]))
            w.writeheader()
            w.writerows(checked)
        if served:
            with o.stage("verify-population.csv").open("w", newline="") as f:
                w = csv.DictWriter(f, fieldnames=list(served[0]))
                w.writeheader()
                w.writerows(served)
        write_json(o.stage("design.json"), {
            "design": str(args.config), "children": found["children"],
            "alpha": list(design.alpha), "transparency_goal_Nm_per_kg": design.goal,
            "demand": found["demand"],
            "chosen": {j: {k: v for k, v in r.items() if not k.startswith("_")}
                       for j, r in found["chosen"].items()},
            "device": str(out / "device"), "verify": checked, "floors": floors,
            "verify_population": population.summary(served) if served else None,
            "wall_time_s": time.perf_counter() - t0})
        o.commit(last="design.json")
    _say(f"exoleg design: {found['children']} children x {len(rows) // 3} candidates per "
         f"joint (the catalogue's motors and gears on {len(design.buses)} bus voltage(s)), "
         f"alpha {'/'.join(f'{a:g}' for a in design.alpha)}")
    _table([[d["joint"], f"{d['child_share_peak_Nm']:.1f} / {d['child_share_rms_Nm']:.1f}",
             f"{d['links_peak_Nm']:.1f} / {d['links_rms_Nm']:.1f}",
             f"{d['together_peak_Nm']:.1f} / {d['together_rms_Nm']:.1f}"]
            for d in found["demand"]],
           ["joint", "the child's share N m (peak / RMS)", "the device's own links",
            "together (assisting)"],
           title="what each joint's unit carries along the gait, the worst child's: the "
                 "share of their moment asked and the device's own links, which the unit "
                 "carries in every mode (the transparent one compensates them)")
    _table([[r["joint"], r["motor"], r["gear"], _series_words(r), f"{r['bus_V']:g}",
             f"{100 * r['served']:.0f} %", f"{r['residual_worst_Nm_per_kg']:.3f}",
             f"{r['winding_worst_C']:.0f}"] for r in found["chosen"].values()],
           ["joint", "motor", "gear", "series", "bus V", "served", "worst residual N m/kg",
            "worst winding degC"], title="chosen (screen: closed forms over the population)")
    _table([[c["device"], f"{c['age']:g} {c['sex']} "
             f"{'TD' if not c['group'] else 'GMFCS ' + str(c['group'])} "
             f"P{c['percentile']:g}", "yes" if c["walked"] else c["fault"],
             str(c["swing_touches"]),
             " / ".join(f"{c['tracking_rms_deg_' + j]:.1f}" for j in ("hip", "knee", "ankle"))]
            for c in checked], ["device", "held-out child", "walked",
                                "the foot touched the belt in swing", "tracking RMS deg"],
           title=f"verified in the walking loop ({design.strides} strides, the held-out "
                 "children as actors, assist-as-needed)")
    _table([[f["joint"], f"{f['law_Nm_per_kg']:.3f}", f"{f['loop_Nm_per_kg']:.3f}",
             f"{f['unread_pelvis_Nm_per_kg']:.3f}",
             "-" if f["rotor_Nm_per_kg"] is None else f"{f['rotor_Nm_per_kg']:.3f}",
             "yes" if f["reachable"] else "no"] for f in floors],
           ["joint", "the law leaves N m/kg", "the loop's floor", "the pelvis unread",
            "the rotor's bound",
            f"<= {design.goal:g} within reach (the rotor's bound, else the loop's)"],
           title="transparent, the 10-year-old girl (P50) on the chosen device, 10 "
                 "strides: what its law leaves, what a law "
                 "knowing the device exactly would (a tick late, through the drive's loop), "
                 "the same law blind to the pelvis's vertical acceleration (no sensor on "
                 "the device reads it), and behind a spring what any law could, the walk "
                 "known ahead (exoleg validate --transparency --device)")
    if args.bounds:
        _table([[f["joint"], "-" if (b := f["catalogue_Nm_per_kg"]) is None else f"{b:.3f}",
                 f["catalogue_unit"] or "none bounded",
                 str(f["catalogue_units"]) + (f" ({f['catalogue_unsolved']} more did not "
                                              "converge)" if f["catalogue_unsolved"] else ""),
                 "-" if b is None else "yes" if b <= design.goal else "no"]
                for f in floors],
               ["joint", "the catalogue's bound N m/kg", "its unit", "units",
                f"<= {design.goal:g} within any unit's reach"],
               title="the same walk through every unit the design could build at each "
                     "joint: the least any law could leave, the walk known ahead (behind a "
                     "series element its rotor following the links within its motor's "
                     "current; rigid, the unit's own rotor and friction beyond its drive's "
                     "envelope)")
    if served:
        summ = population.summary(served)
        _table([[name, str(v["children"]), f"{100 * v['transparent_met']:.0f} %",
                 f"{100 * v['assist_met']:.0f} %", f"{100 * v['served']:.0f} %",
                 f"{100 * v['touched_in_swing']:.0f} %",
                 " / ".join(f"{x:.3f}" for x in v["residual_worst_Nm_per_kg"].values())]
                for name, v in summ.items()],
               ["children", "n", f"transparent <= {design.goal:g} N m/kg",
                "assist-as-needed clean", "both", "the foot touched the belt in swing",
                "worst residual hip / knee / ankle"],
               title=f"verified in the walking loop ({design.strides_transparent} strides "
                     f"transparent, {design.strides_assist} assist-as-needed)")
    _say(f"wrote {out}/: screen.csv, verify.csv, design.json, device/actuators/ "
         f"({time.perf_counter() - t0:.1f} s); walk it: exoleg simulate --walk --device "
         f"{out / 'device'}")
    return 0


def transparency_floors(design: Any, device: Path,
                        rows: list[dict[str, Any]] | None = None) -> list[dict[str, Any]]:
    """Per joint, the chosen device's transparent residual against its floors on the
    typically developing 10-year-old girl's walk of 10 strides
    (:func:`exoleg.validate.transparency.evaluate`): the law's, the loop's floor, a
    compliant unit's rotor bound (None for a rigid one), and whether the goal is within
    reach: behind a spring, of the rotor's bound (a relaxation no law goes below); at a
    rigid joint, of the loop's floor (a law that knows the device exactly, a tick late,
    is what there is -- not a bound on a law with the walk's preview: with springs of
    1000 / 830 / 690 N m/rad the example's ankle law left 0.071 N m/kg against that
    floor's 0.085 on the same walk). With the screen's ``rows``, the catalogue's bound on
    that walk too: the least :func:`~exoleg.validate.transparency.unit_bound` over every
    screened unit the design could build at the joint (its torque loop closes), and that
    unit in words -- the goal out of every unit's reach, whatever the law, when it is
    above."""
    from exoleg.validate.transparency import evaluate, links_need

    v = evaluate(strides=10, stride_time=design.stride_time, device=device)
    assert v.need is not None
    links = None if rows is None else links_need(v.leg, v.need)
    law = v.rows[-1]["rms_Nm_per_kg"]
    out = []
    for j, f in enumerate(v.floors):
        rotor = None if math.isnan(f["floor_rotor_Nm_per_kg"]) else float(
            f["floor_rotor_Nm_per_kg"])
        out.append({"joint": f["joint"], "law_Nm_per_kg": float(law[f["joint"]]),
                    "loop_Nm_per_kg": float(f["floor_loop_Nm_per_kg"]),
                    "unread_pelvis_Nm_per_kg": float(f["floor_unread_pelvis_Nm_per_kg"]),
                    "rotor_Nm_per_kg": rotor,
                    "reachable": (f["floor_loop_Nm_per_kg"] if rotor is None
                                  else rotor) <= design.goal})
        if rows is not None:
            out[-1].update(_catalogue_bound(f["joint"], j, rows, v, links))
    return out


def _catalogue_bound(joint: str, j: int, rows: list[dict[str, Any]], v: Any,
                     links: Any) -> dict[str, Any]:
    """The least :func:`~exoleg.validate.transparency.unit_bound` at ``joint`` (index
    ``j``) over the screen's ``rows`` the design could build, on the walk of ``v`` (an
    :func:`~exoleg.validate.transparency.evaluate` result; ``links``: its links' need):
    the bound, its unit in words, how many units were bounded and how many programmes
    did not converge (no bound: counted, the rest stand)."""
    from exoleg.design.catalogue import candidate
    from exoleg.validate.transparency import unit_bound

    bounds: dict[tuple[Any, ...], tuple[float, str]] = {}
    unsolved: set[tuple[Any, ...]] = set()
    for r in rows:
        m, g, series = r["_parts"]
        # behind a series element the bus is not in the bound: each unit once
        key = (r["motor"], r["gear"], r["series"], r["stiffness_Nm_per_rad"],
               r["bus_V"] if series is None else None)
        if r["joint"] != joint or r["why_not"] or key in bounds or key in unsolved:
            continue
        try:
            b = unit_bound(candidate(joint, m, g, r["bus_V"], series), j, v.need, links,
                           v.body_mass)
        except RuntimeError:  # its programme did not converge: no bound, said
            unsolved.add(key)
            continue
        bounds[key] = (b, f"{r['motor']}, {r['gear']}, {_series_words(r)}"
                       + (f", {r['bus_V']:g} V" if series is None else ""))
    # (none bounded -- every unit's loop unclosed or its programme unconverged: None)
    least, unit = min(bounds.values(), default=(None, None))
    return {"catalogue_Nm_per_kg": least, "catalogue_unit": unit,
            "catalogue_units": len(bounds), "catalogue_unsolved": len(unsolved)}


def _series_words(r: dict[str, Any]) -> str:
    """A screen row's series element in words."""
    if r["series"] == "rigid":
        return "rigid"
    return f"{r['series'].replace('_', ' ')} {r['stiffness_Nm_per_rad']:.0f} N m/rad"


def add_parser(sub: Any) -> None:
    """Add ``exoleg design`` to the subcommands ``sub``."""
    d = sub.add_parser("design", help="choose the actuation for a population of children "
                       "(motors and gears of the catalogue, screened, verified walking)")
    d.add_argument("config", type=Path, help="design file (TOML): examples/design-*.toml")
    d.add_argument("--out", type=Path, default=Path("exoleg-design"))
    d.add_argument("--scheduler", default=None, metavar="ADDRESS",
                   help="the population's walks on this Dask scheduler (tcp://host:port or "
                   "a scheduler file); default a local cluster")
    d.add_argument("--workers", type=_count(1, 256), default=None, metavar="N",
                   help="the local cluster's workers (default one per core)")
    d.add_argument("--no-population", action="store_true",
                   help="screen, choose and walk the held-out children only: leave out the "
                   "population's walks on the sweep engine")
    d.add_argument("--bounds", action="store_true",
                   help="also bound every unit the design could build at each joint on the "
                   "girl's transparent walk: can any catalogue unit meet the goal, whatever "
                   "the law (about 40 s more)")
    d.set_defaults(func=cmd_design)
