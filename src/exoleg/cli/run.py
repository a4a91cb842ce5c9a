"""``exoleg run``: a session on the device or a simulated one at a fixed rate, logged;
``--hmi`` serves the operator interface for it."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from exoleg.cli._common import (
    STRIDE_TIME_RANGE,
    WEB_HOST,
    WEB_PORT,
    _body_mass,
    _bus_options,
    _child_on_leg,
    _count,
    _device_option,
    _mass_of,
    _read_leg,
    _say,
    _table,
    _url,
    _web_options,
    _within,
)
from exoleg.entry import CONTROLLERS, DEFAULT_BODY_MASS


def cmd_run(args: argparse.Namespace) -> int:
    from exoleg.runtime.session import check_options, run, summarize

    _bus_options("exoleg run", args.backend, interface=args.interface,
                 bus_timeout=args.bus_timeout, channel=args.channel)
    _refuse_unapplied(args)
    args.channel = args.channel or "exoleg"
    args.seed = args.seed or 0
    if not args.child and args.body_mass is None:
        args.body_mass = DEFAULT_BODY_MASS
    args.hmi_host = args.hmi_host or WEB_HOST
    args.hmi_port = args.hmi_port or WEB_PORT
    bus_timeout = None if args.bus_timeout is None else args.bus_timeout * 1e-3
    check_options(args.backend, args.interface, args.arm, args.walk_after, bus_timeout,
                  controller=args.controller, link=True if args.hmi else None)
    leg = child = None
    if args.leg:
        leg, _ = _read_leg(args.leg, refuse_unfit="exoleg run")
    if args.child:
        from exoleg.child.model import ChildModel

        child = ChildModel.load(args.child)
        _child_on_leg(child, args.leg, "exoleg run")
        args.body_mass = _mass_of(child, args.body_mass, "exoleg run")
    link = web = None
    if args.hmi:
        import secrets

        from exoleg.hmi.serving import bind_check, start_process
        from exoleg.runtime.link import LoopLink
        from exoleg.runtime.session import check_folder

        warning = bind_check(args.hmi_host, args.tls_cert, args.tls_key)
        link, token = LoopLink.new(), secrets.token_urlsafe(16)
        web = start_process(link, check_folder(args.out), token, args.hmi_host,
                            args.hmi_port, args.tls_cert, args.tls_key, args.backend,
                            str(args.leg) if args.leg else None,
                            plan=(args.duration, args.body_mass))
        if warning:
            _say(warning)
        _say(f"operator interface: {_url(args.hmi_host, args.hmi_port, args.tls_cert)}"
             f"/#token={token}\ntoken (for every control action): {token}", flush=True)
    try:
        res, path = run(args.backend, args.duration, args.out, period=1.0 / args.rate,
                        arm=args.arm, walk_after=args.walk_after, leg=leg,
                        body_mass=args.body_mass, seed=args.seed,
                        realtime=not args.no_realtime, interface=args.interface,
                        channel=args.channel, link=link, bus_timeout=bus_timeout,
                        controller=args.controller, child=child, device=args.device,
                        expected_stride=args.expected_stride)
    finally:
        if web is not None:
            web.terminate()
            web.join(timeout=5)
    s = summarize(path)
    t = res.timing
    _say(f"exoleg run --backend {args.backend} --controller {args.controller}: {res.ticks} "
         f"ticks at {args.rate:g} Hz, ended "
         f"by {res.stopped_by}" + (f" ({', '.join(res.realtime)})" if res.realtime else ""))
    _table([[f"{t.get('p50_us', 0):.1f}", f"{t.get('p99_us', 0):.1f}",
             f"{t.get('p999_us', 0):.1f}", f"{t.get('max_us', 0):.1f}",
             str(t.get("missed", 0))]],
           ["late p50 us", "p99 us", "p99.9 us", "max us", "deadlines missed (> 1 period)"])
    from exoleg.tick import Mode, name_of

    _say("ticks per mode: " + ", ".join(f"{name_of(Mode, m)} {n}"
                                        for m, n in s["ticks_per_mode"].items())
         + f"; initial contacts {s['initial_contacts']}"
         + (f"; safety fault at {s['first_fault_s']:.3f} s" if s["first_fault_s"] else ""))
    if s["winding_max_C"]:
        _say("motors (the safety layer's estimates): winding max "
             + ", ".join(f"{j} {v:.1f}" for j, v in s["winding_max_C"].items())
             + " degC; gear torque max " + ", ".join(f"{j} {v:.0f}" for j, v in
                                                   s["gear_peak_Nm"].items())
             + f" N m; ticks with a gear beyond its momentary peak "
               f"{s['ticks_gear_beyond_momentary_peak']}")
    if s["interaction_rms_Nm"]:
        _say("interaction torque (the cuffs on the child), RMS: "
             + ", ".join(f"{j} {v:.1f}" for j, v in s["interaction_rms_Nm"].items())
             + " N m (" + ", ".join(f"{v:.2f}" for v in
                                    (s["interaction_rms_Nm_per_kg"] or {}).values())
             + " N m/kg); peak " + ", ".join(f"{v:.0f}" for v in
                                             s["interaction_peak_Nm"].values()) + " N m")
    if s["support_by_stride"]:
        _say("support per stride (1: the impedance's, 0: transparent): "
             + ", ".join(f"{v:.2f}" for v in s["support_by_stride"]))
    _say("the safety layer: " + ("; ".join(f"{e['text']} ({e['ticks']} ticks from "
                                          f"{e['first_s']:.3f} s)" for e in s["safety_events"])
                                 or "nothing to do"))
    from exoleg.session_log import MAX_LOSS_TICKS

    _say(f"\nwrote {path} (crash-safe: at most {MAX_LOSS_TICKS} ticks lost if killed) and "
         f"{Path(args.out) / 'run.json'}")
    stopped = res.stopped_by
    return 0 if stopped.startswith("duration") else (130 if stopped.startswith("signal") else 1)


def _refuse_unapplied(args: argparse.Namespace) -> None:
    """Refuses an option that would not apply (ParameterError naming it): the bus's on
    the other bus, the simulated child's where no simulated device answers, the
    interface's without --hmi."""
    from exoleg.errors import ParameterError
    from exoleg.runtime.session import simulated

    if args.channel is not None and args.backend != "canopen":
        raise ParameterError("exoleg run", "--channel", "goes with --backend canopen")
    sim = simulated(args.backend, args.interface)
    if args.seed is not None and not sim:
        raise ParameterError("exoleg run", "--seed", "the simulated sensors' noise: not on "
                             f"a real bus ({args.backend} --interface {args.interface})")
    if args.child is not None and not sim:
        raise ParameterError("exoleg run", "--child", "the simulated child: not on a real "
                             f"bus ({args.backend} --interface {args.interface}), where the "
                             "child is real")
    from exoleg.entry import WALKING_CONTROLLERS

    if args.expected_stride is not None and args.controller not in WALKING_CONTROLLERS:
        raise ParameterError("exoleg run", "--expected-stride", "the stride the walking "
                             f"controller expects: not {args.controller!r}'s (walking: "
                             f"{', '.join(WALKING_CONTROLLERS)})")
    for name in ("hmi_host", "hmi_port", "tls_cert", "tls_key"):
        if getattr(args, name) is not None and not args.hmi:
            raise ParameterError("exoleg run", "--" + name.replace("_", "-"),
                                 "goes with --hmi")


def add_parser(sub: Any) -> None:
    """Add ``exoleg run`` to the subcommands ``sub``."""
    r = sub.add_parser("run", help="drive the device (or a simulated one) at a fixed rate: "
                       "sensors -> control hierarchy -> safety layer -> drives, logged")
    r.add_argument("--backend", choices=["sim", "canopen", "ethercat"], default="sim",
                   help="sim: the simulated device in real time; canopen: CiA 402 drives and "
                        "the foot board over CAN; ethercat: the same over EtherCAT (pysoem)")
    r.add_argument("--interface", help="canopen: python-can interface, 'virtual' (default: "
                   "hardware in the loop with simulated nodes) or e.g. 'socketcan'; "
                   "ethercat: network interface (e.g. eth0), or 'fake' (default: simulated "
                   "slaves at the process-data level)")
    r.add_argument("--channel", help="canopen: the bus channel (e.g. can0; default exoleg, "
                   "the virtual bus's)")
    r.add_argument("--bus-timeout", type=_within(0.1, 50.0, " ms"),
                   help="canopen/ethercat: how long the master waits for every node's answer "
                        "before it is a fault, ms (default 5; 20 on simulated nodes, threads "
                        "of this computer)")
    r.add_argument("--controller", default="walk", metavar="{" + ",".join(CONTROLLERS)
                   + "} or FILE.py:NAME",
                   help="walk: the walking hierarchy (default), in its impedance mode; "
                        "impedance, transparent: the same starting in that support mode "
                        "(the operator may switch); pd-gravity, pd, "
                        "computed-torque: the paper's law following its scenario (stance "
                        "and swing postures every 3 s from the walk command; held at rest "
                        "while standing); FILE.py:NAME or MODULE:NAME: a law of your own "
                        "on the same scenario, behind the same supervisor and safety layer "
                        "(docs/extending/controller.md)")
    r.add_argument("--duration", type=_within(0.01, 86400.0, " s"), required=True, help="s")
    r.add_argument("--rate", type=_within(10.0, 10000.0, " Hz"), default=1000.0,
                   help="control rate, Hz (default 1000)")
    r.add_argument("--arm", action="store_true",
                   help="sim: the operator's arming, given at start (no motion without it)")
    r.add_argument("--walk-after", type=_within(0.0, 86400.0, " s"),
                   help="sim: the operator's walk command this many seconds in (needs --arm)")
    r.add_argument("--leg", type=Path, help="leg file (from exoleg fit); default the paper's")
    r.add_argument("--body-mass", type=_body_mass,
                   help="the simulated child's mass, kg (default 30; with --child: theirs)")
    r.add_argument("--child", type=Path, metavar="FILE",
                   help="simulated device: the child as an actor (child.toml, written by "
                        "exoleg fit): passive moments, spasticity, their own effort -- a "
                        "disarmed GMFCS I-II child stands by themselves; its mass replaces "
                        "--body-mass")
    r.add_argument("--expected-stride", type=_within(*STRIDE_TIME_RANGE, " s"),
                   help="the child's own stride, s (their last session's): what the walking "
                        "controller expects until it has measured theirs (default 1.1)")
    r.add_argument("--seed", type=_count(0, 2**31 - 1), help="simulated device: its "
                   "sensors' noise (default 0)")
    r.add_argument("--hmi", action="store_true",
                   help="serve the operator interface (and its control API) for this session")
    _web_options(r, "--hmi-host", "--hmi-port", given=True)
    r.add_argument("--no-realtime", action="store_true",
                   help="do not ask for SCHED_FIFO (nor an isolated CPU, nor the bus threads' "
                        "priority)")
    r.add_argument("--out", type=Path, default=Path("exoleg-session"))
    _device_option(r, "the actuators' scaling and limits, the safety limits, the "
                      "controller's settings and, simulated, the device itself")
    r.set_defaults(func=cmd_run)
