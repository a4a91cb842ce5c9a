"""``exoleg design``: the actuation chosen for a population (:mod:`exoleg.design.study`)."""

from __future__ import annotations

import argparse
import time
from pathlib import Path
from typing import Any

from exoleg.cli._common import _say, _table


def cmd_design(args: argparse.Namespace) -> int:
    import csv

    from exoleg.design.study import Design, run_design, verify
    from exoleg.io import OutputFolder, refuse_overwrite, write_json

    t0 = time.perf_counter()
    design = Design.load(args.config)
    out = Path(args.out)
    actuators = out / "device" / "actuators"
    files = ("hip.toml", "knee.toml", "ankle.toml")
    # before the screen and the walks: none of the user's files is written over
    refuse_overwrite(out, "exoleg design", ("screen.csv", "verify.csv", "design.json"))
    refuse_overwrite(actuators, "exoleg design", files)
    found = run_design(design)
    rows = found["rows"]
    with OutputFolder(actuators, owner="exoleg design") as dev:
        for j, text in found["text"].items():
            dev.stage(f"{j}.toml").write_text(text)
        dev.commit()
    checked = verify(design, None) + verify(design, out / "device")
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
        write_json(o.stage("design.json"), {
            "design": str(args.config), "children": found["children"],
            "alpha": list(design.alpha), "transparency_goal_Nm_per_kg": design.goal,
            "chosen": {j: {k: v for k, v in r.items() if not k.startswith("_")}
                       for j, r in found["chosen"].items()},
            "device": str(out / "device"), "verify": checked,
            "wall_time_s": time.perf_counter() - t0})
        o.commit(last="design.json")
    _say(f"exoleg design: {found['children']} children x {len(rows) // 3} candidates per "
         f"joint (the catalogue's motors and gears on {len(design.buses)} bus voltage(s)), "
         f"alpha {'/'.join(f'{a:g}' for a in design.alpha)}")
    _table([[r["joint"], r["motor"], r["gear"], f"{r['bus_V']:g}",
             f"{100 * r['served']:.0f} %", f"{r['residual_worst_Nm_per_kg']:.3f}",
             f"{r['winding_worst_C']:.0f}"] for r in found["chosen"].values()],
           ["joint", "motor", "gear", "bus V", "served", "worst residual N m/kg",
            "worst winding degC"], title="chosen (screen: closed forms over the population)")
    _table([[c["device"], f"{c['age']:g} {c['sex']} "
             f"{'TD' if not c['group'] else 'GMFCS ' + str(c['group'])} "
             f"P{c['percentile']:g}", "yes" if c["walked"] else c["fault"],
             " / ".join(f"{c['tracking_rms_deg_' + j]:.1f}" for j in ("hip", "knee", "ankle"))]
            for c in checked], ["device", "held-out child", "walked", "tracking RMS deg"],
           title=f"verified in the walking loop ({design.strides} strides, impedance)")
    _say(f"wrote {out}/: screen.csv, verify.csv, design.json, device/actuators/ "
         f"({time.perf_counter() - t0:.1f} s); walk it: exoleg simulate --walk --device "
         f"{out / 'device'}")
    return 0


def add_parser(sub: Any) -> None:
    """Add ``exoleg design`` to the subcommands ``sub``."""
    d = sub.add_parser("design", help="choose the actuation for a population of children "
                       "(motors and gears of the catalogue, screened, verified walking)")
    d.add_argument("config", type=Path, help="design file (TOML): examples/design-*.toml")
    d.add_argument("--out", type=Path, default=Path("exoleg-design"))
    d.set_defaults(func=cmd_design)
