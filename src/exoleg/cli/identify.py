"""``exoleg identify``: the child + device leg identified on the device from its own
encoders and drive currents, through the runtime."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from exoleg.cli._common import (
    _bus_options,
    _child_on_leg,
    _count,
    _device_option,
    _read_leg,
    _say,
    _table,
    _within,
)


def cmd_identify(args: argparse.Namespace) -> int:
    from exoleg.errors import ParameterError
    from exoleg.identify.device import identify_device
    from exoleg.plots.identify import identify_figure
    from exoleg.runtime.session import simulated

    _bus_options("exoleg identify", args.backend, interface=args.interface,
                 channel=args.channel)
    if args.sim_leg is not None and not simulated(args.backend, args.interface):
        raise ParameterError("exoleg identify", "--sim-leg", "the simulated device's leg: "
                             f"not on a real bus ({args.backend} --interface "
                             f"{args.interface})")
    leg = truth = child = None
    if args.leg:
        leg, _ = _read_leg(args.leg, refuse_unfit="exoleg identify")
    if args.sim_leg:
        truth, _ = _read_leg(args.sim_leg)
    if args.child:
        from exoleg.child.model import ChildModel

        child = ChildModel.load(args.child)
        _child_on_leg(child, args.leg, "exoleg identify")
    r = identify_device(args.backend, args.out, leg=leg, child=child,
                        duration=args.duration, seed=args.seed, interface=args.interface,
                        channel=args.channel or "exoleg",
                        realtime=not args.no_realtime, truth=truth,
                        device_alone=args.device_alone,
                        identified_device=args.identified_device, figure=identify_figure,
                        device=args.device)
    s = r.summary()
    _say(f"exoleg identify --backend {args.backend}: a plan of {s['plan']['periods']} x "
         f"{s['plan']['period_s']:g} s (condition number {s['plan']['condition_number']:.1f}"
         f"), {s['plan']['duration_s']:g} s with the moves in and out; "
         f"{s['samples']} samples fitted")
    _table([[j, f"{s['residual_rms_nm'][j]:.3f}", f"{s['held_out_rms_nm'][j]:.3f}",
             f"{s['held_out_pct'][j]:.1f}"] for j in s["residual_rms_nm"]],
           ["joint", "fit residual RMS N m", "held-out error RMS N m", "held-out, % of RMS"],
           title="the identified leg against the drives' torque")
    _table([[str(row["parameter"]), f"{row['value']:.5g}", f"{row['sd']:.2g}",
             f"{row['low95']:.5g} to {row['high95']:.5g}"]
            for row in r.identified.table()],
           ["base parameter", "value", "SD", "95 % interval"])
    if "child_share" in s:
        _table([[k, f"{v:.5g}"] for k, v in s["child_share"].items()],
               ["base parameter", "the child's share"],
               title="the child: the identified leg less the identified device")
    out = Path(args.out)
    _say(f"wrote {out / 'leg.toml'} (loadable with --leg), {out / 'parameters.csv'}, "
         f"{out / 'identify.png'}, {out / 'identify.json'} and the session in "
         f"{out / 'session'}")
    return 0


def add_parser(sub: Any) -> None:
    """Add ``exoleg identify`` to the subcommands ``sub``."""
    d = sub.add_parser(
        "identify", help="identify the child + device leg on the device",
        description="Design an excitation plan for the fitted leg (within the safety "
        "layer's range less 5 deg, 60 deg/s, 60 % of its torque), play it through the "
        "runtime (armed, supervised, E-stop and faults as in every session) with the child "
        "relaxed, and identify the leg's inertial parameters and the joints' friction from "
        "the encoders and the drives' torque, the last period held out. Writes the "
        "identified leg file, the parameters with 95 % intervals, a figure of the held-out "
        "torque against the prediction, a summary and the session's log.")
    d.add_argument("--backend", choices=["sim", "canopen", "ethercat"], default="sim",
                   help="sim: the simulated device; canopen / ethercat: the drives over the "
                        "bus (simulated nodes: --interface virtual / fake, the defaults)")
    d.add_argument("--interface", help="canopen: 'virtual' (default); ethercat: 'fake' "
                   "(default)")
    d.add_argument("--channel", help="canopen: the bus channel (default exoleg)")
    d.add_argument("--leg", type=Path, help="the fitted leg file (from exoleg fit): the "
                   "prior and what the plan is designed on; default the paper's")
    d.add_argument("--child", type=Path, metavar="FILE",
                   help="the child in the device (child.toml, from exoleg fit): their "
                        "passive moments are held at their model; simulated device: the "
                        "child as an actor, relaxed")
    d.add_argument("--device-alone", action="store_true",
                   help="the first stage: the device with no child in it, its telescopes "
                        "set for --leg (identify a device once; then "
                        "--identified-device)")
    d.add_argument("--identified-device", type=Path, metavar="DIR",
                   help="the folder of an identification of the device alone: its result "
                        "is the device's share of the prior, and the child's share of the "
                        "base parameters is reported (Li et al. 2022's stages)")
    d.add_argument("--sim-leg", type=Path, metavar="FILE",
                   help="simulated device: the leg it carries, when not --leg's (the "
                        "child's true segments; to see identification at work)")
    d.add_argument("--duration", type=_within(10.0, 120.0, " s"), default=120.0,
                   help="the plan's length, s (10-120; default 120), besides the moves in "
                        "and out (2 s each or longer, at a comfortable speed)")
    d.add_argument("--seed", type=_count(0, 2**31 - 1), default=0,
                   help="the plan's design and the simulated sensors' noise (default 0)")
    d.add_argument("--no-realtime", action="store_true",
                   help="do not ask for SCHED_FIFO")
    d.add_argument("--out", type=Path, default=Path("exoleg-identify"))
    _device_option(d, "the actuators the plan is designed for, the safety limits and "
                      "controller it runs under and, simulated, the device itself")
    d.set_defaults(func=cmd_identify)
