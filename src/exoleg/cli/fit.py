"""``exoleg fit``: the device fitted to one child -- dimensions, settings, verdict,
margins, the personalized leg file."""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

from exoleg.cli._common import (
    STRIDE_TIME_RANGE,
    _device_option,
    _percentile,
    _say,
    _table,
    _within,
)
from exoleg.entry import CHILD_ENTRY, MEASURED


# --------------------------------------------------------------------------- fit
def _name(text: str) -> str:
    """A child's name as typed: not blank (left out, it is 'child')."""
    if not text.strip():
        raise argparse.ArgumentTypeError(f"{text!r} is blank: give the child's name, or "
                                         "leave --name out ('child')")
    return text


def cmd_fit(args: argparse.Namespace) -> int:
    import warnings

    import numpy as np

    from exoleg.design.demand import DISPLAY
    from exoleg.design.report import fit_report
    from exoleg.device.actuator import paper_actuators
    from exoleg.io import OutputFolder
    from exoleg.sizing import Child

    measured = {k: (getattr(args, k) / 100 if getattr(args, k) is not None else None)
                for k in MEASURED}
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        child = Child(age=args.age, sex=args.sex, height=args.height / 100, mass=args.mass,
                      gmfcs=args.gmfcs, affected_side=args.side, name=args.name,
                      accept_unusual=args.accept_unusual, **measured)
    for w in caught:
        _say(f"warning: {w.message}")
    acts = None if args.device is None else paper_actuators(args.device)
    with OutputFolder(args.out, owner="exoleg fit") as out:
        rep = fit_report(child, args.leg_length_method, percentile=args.percentile,
                         speed=args.speed, stride_time=args.stride_time,
                         simulate=not args.no_simulate, actuators=acts)
        fit, demand, over = rep.fit, rep.demand, rep.over
        d = fit.dimensions
        charts = child.charts
        chart_text = charts["height"] + (f", weight {charts['weight']}"
                                         if charts["weight"] != charts["height"] else "")
        _say(f"{child.name}: {child.age:g} y {child.sex}, {child.height * 100:.1f} cm, "
             f"{child.mass:.1f} kg, {'GMFCS ' + str(child.gmfcs) if child.gmfcs else 'TD'} "
             f"({chart_text} chart)")
        _table([[k, f"{getattr(d, k) * 100:.1f}", d.sources[k]] for k in
                ("thigh", "shank", "ankle_height", "foot_length", "leg_length")],
               ["dimension", "cm", "source"])
        _say(f"geometric fit: {'FITS' if fit.fits else 'DOES NOT FIT'}")
        _say(f"  upper telescope (hip-knee) {fit.upper * 100:.1f} cm (27-40), lower telescope "
             f"(knee-sole) {fit.lower * 100:.1f} cm (33-46), footplate 23.5 cm")
        for m in fit.misses:
            _say(f"  misses: {m.what}: child {m.child * 100:.1f} cm, allowed "
                 f"{m.allowed[0] * 100:.1f}-{m.allowed[1] * 100:.1f} cm, by {m.by * 100:+.2f} cm")
        pr = fit.paper_rule
        _say(f"  paper's Table 1 rule: leg length {pr['leg_length'] * 100:.1f} cm vs 60-86 cm -> "
             f"{'fits' if pr['fits'] else 'does not fit'}")
        rom = fit.range_of_motion
        _say("  normative gait range (mean +- 2 SD) vs device range of motion, deg: " + ", ".join(
            f"{j} {np.degrees(rom['gait_lower'][i]):.0f}.."
            f"{np.degrees(rom['gait_upper'][i]):.0f} in "
            f"{np.degrees(rom['device_lower'][i]):.0f}..{np.degrees(rom['device_upper'][i]):.0f}"
            for i, j in enumerate(("hip", "knee", "ankle"))))
        rows = []
        for r in demand.table():
            u, k = DISPLAY[r["quantity"]]
            rows.append([r["source"], f"{r['quantity']} ({u})"] + [
                f"{r[j] * k:.1f} ({r[j + '_margin']:.2f})" + ("" if r[j + "_margin"] >= 1 else " !")
                for j in ("hip", "knee", "ankle")])
        from exoleg.design.demand import table2_limits

        for name, lim in (("device limits (datasheets)", demand.limits),
                          ("Table 2 (paper, for reference)", table2_limits())):
            rows.append([name, "torque / speed / power"] + [
                f"{lim[0, j]:.0f} / {np.degrees(lim[1, j]):.0f} / {lim[2, j]:.0f}"
                for j in range(3)])
        _table(rows, ["source", "quantity", "hip", "knee", "ankle"],
               title="actuator demand (margin = limit / demand; ! = over the limit)")
        mg, src, qn, joint = demand.smallest_margin()
        if over:
            _say(f"actuator demand: EXCEEDS the device's limits in {len(over)} case(s):")
            for e in over:
                _say(f"  {e}")
        else:
            _say("actuator demand: within the device's limits (smallest margin "
                 f"{mg:.2f}: {qn} at the "
                 f"{joint}, {src})")
        _say(f"\nverdict: {rep.verdict}")
        write_leg = fit.fits or args.write_leg
        out.stage("fit.json").write_text(json.dumps(rep.record(write_leg), indent=2))
        written = ["fit.json"]
        if child.gmfcs != 5:
            from exoleg.child.model import ChildModel

            cm = ChildModel.of(child, args.contracture, args.spasticity, args.crouch)
            out.stage("child.toml").write_text(cm.to_toml())
            written.insert(0, "child.toml")
        if write_leg:
            rep.save_leg(out.stage("leg.toml"))
            written.insert(0, "leg.toml")
        out.commit(last="fit.json")
    if "child.toml" in written:
        _say(f"wrote {out.folder}/child.toml (for exoleg simulate --walk --child)")
    else:
        _say("no child.toml: the child model covers typically developing children and "
             "GMFCS I-IV, the device's users")
    if "leg.toml" in written:
        _say(f"wrote {out.folder}/leg.toml (for exoleg simulate --leg) and {out.folder}/fit.json")
    else:
        _say(f"wrote {out.folder}/fit.json; no leg file: the device does not fit this child "
             "(--write-leg writes one anyway, marked as such)")
    return 0


def add_parser(sub: Any) -> None:
    """Add ``exoleg fit`` to the subcommands ``sub``."""
    f = sub.add_parser("fit", help="fit the device to one child: dimensions, settings, verdict, "
                       "margins; writes the personalized leg file")
    entry = {k: _within(lo, hi, " " + unit) for k, (lo, hi, unit) in CHILD_ENTRY.items()}
    f.add_argument("--age", type=entry["age"], required=True,
                   help="years (2-20; the device targets 8-12)")
    f.add_argument("--sex", choices=["female", "male"], required=True)
    f.add_argument("--height", type=entry["height"], required=True, help="cm")
    f.add_argument("--mass", type=entry["mass"], required=True, help="body mass, kg")
    f.add_argument("--gmfcs", type=int, choices=[0, 1, 2, 3, 4, 5], default=0,
                   help="GMFCS level; 0 = typically developing (WHO 2007 / CDC 2000 charts)")
    f.add_argument("--side", choices=["left", "right"], default="right")
    for name in MEASURED:
        f.add_argument(f"--{name.replace('_', '-')}", type=entry["measured"],
                       help=f"measured {name.replace('_', ' ')}, cm")
    f.add_argument("--accept-unusual", action="store_true",
                   help="accept measured dimensions outside what is plausible for the height")
    f.add_argument("--leg-length-method", choices=["linear", "drillis", "table1"],
                   default="linear")
    f.add_argument("--percentile", type=_percentile, default=50.0, help="gait demand percentile")
    f.add_argument("--speed", default="Free",
                   choices=["VerySlow", "Slow", "Free", "Fast", "VeryFast"])
    f.add_argument("--stride-time", type=_within(*STRIDE_TIME_RANGE, " s"), default=1.1,
                   help="s per gait cycle, 0.4-4")
    f.add_argument("--no-simulate", action="store_true", help="skip the simulated gait demand")
    f.add_argument("--write-leg", action="store_true",
                   help="write leg.toml even when the device does not fit (marked as such)")
    f.add_argument("--spasticity", choices=["none", "mild", "moderate", "severe"],
                   default="none", help="the child model's spasticity preset (child.toml)")
    f.add_argument("--crouch", type=int, choices=[0, 1, 2, 3, 4, 5], default=0,
                   help="the child's intended gait: 0 normative, 1-5 Rozumalski & Schwartz "
                        "2009's crouch cluster (child.toml)")
    f.add_argument("--contracture", choices=["none", "predictcpgait"], default="none",
                   help="the child model's contracture preset (child.toml): none, or the "
                        "predictcpgait child's (Falisse et al. 2020)")
    f.add_argument("--name", type=_name, default="child",
                   help="the child's name in their files (default 'child')")
    f.add_argument("--out", type=Path, default=Path("exoleg-fit"))
    _device_option(f, "the actuators the child's demand is judged against")
    f.set_defaults(func=cmd_fit)
