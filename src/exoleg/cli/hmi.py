"""``exoleg hmi``: the operator interface."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from exoleg.cli._common import _bus_options, _device_option, _say, _url, _web_options


def cmd_hmi(args: argparse.Namespace) -> int:
    from exoleg.hmi.server import HMI
    from exoleg.hmi.serving import bind_check, listen, serve
    from exoleg.io import _writable_folder
    from exoleg.runtime.session import SIMULATED_BUS, simulated

    _bus_options("exoleg hmi", args.backend, interface=args.interface, channel=args.channel)
    if args.channel is not None and args.backend != "canopen":
        from exoleg.errors import ParameterError

        raise ParameterError("exoleg hmi", "--channel", "goes with --backend canopen")
    warning = bind_check(args.host, args.tls_cert, args.tls_key)
    interface = args.interface or SIMULATED_BUS.get(args.backend)
    # a real device is held from here on (refused when another process holds it)
    hmi = HMI(_writable_folder(args.sessions), backend=args.backend, interface=interface,
              channel=args.channel or "exoleg", device_dir=args.device)
    try:
        sock = listen(args.host, args.port)  # a port in use is said now, in one line
    except BaseException:
        hmi.close()
        raise
    if warning:
        _say(warning)
    _say("the simulated device: it runs beside any other simulated one" if
          simulated(args.backend, interface) else
          f"the device on {interface}" + (f" channel {args.channel or 'exoleg'}" if
                                          args.backend == "canopen" else "")
          + ": held by this interface alone while it runs")
    _say(f"operator interface: {_url(args.host, args.port, args.tls_cert)}/#token="
         f"{hmi.api.token}\ntoken (for every control action): {hmi.api.token}\n"
         f"sessions are recorded in {hmi.root}; Ctrl-C stops the interface (a running "
         "session ends, torque off)", flush=True)
    stopped = serve(hmi, args.host, args.port, args.tls_cert, args.tls_key, sock=sock)
    _say(f"operator interface stopped ({stopped or 'server ended'})")
    return 130 if stopped else 0  # stopped by a signal, as exoleg run


def add_parser(sub: Any) -> None:
    """Add ``exoleg hmi`` to the subcommands ``sub``."""
    h = sub.add_parser("hmi", help="the operator interface: fit a child, run and watch "
                       "sessions, review recorded ones (a web page on this machine)")
    h.add_argument("--backend", choices=["sim", "canopen", "ethercat"], default="sim",
                   help="what the sessions drive (default: the simulated device)")
    h.add_argument("--interface", help="canopen/ethercat: as for exoleg run (default: the "
                   "simulated nodes)")
    h.add_argument("--channel", help="canopen: the bus channel (e.g. can0; default exoleg)")
    _web_options(h, "--host", "--port")
    h.add_argument("--sessions", type=Path, default=Path("exoleg-sessions"),
                   help="folder of recorded sessions and fitted children")
    _device_option(h, "what the sessions and identifications drive with, what a fit is "
                      "judged against and what the Live page draws")
    h.set_defaults(func=cmd_hmi)
