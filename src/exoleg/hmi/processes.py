"""A session's own process under ``exoleg hmi``: the loop, or an identification, each in
a process of its own started from the *Control* page, talking to the server through a
:class:`~exoleg.runtime.link.LoopLink`."""

from __future__ import annotations

import contextlib
import os
import time
from pathlib import Path
from typing import Any

from exoleg.io import write_json
from exoleg.runtime.link import LoopLink

#: an identification session's own folder for what it identified
IDENTIFIED = "identified"


def _session_process(link: LoopLink, backend: str, interface: str | None, duration: float,
                     folder: str, leg_path: str | None, body_mass: float, arm: bool,
                     cpus: set[int] | None, child_path: str | None = None,
                     channel: str = "exoleg", device: str | None = None) -> None:
    """A session's own process (``exoleg hmi``): runs the loop until its duration, an
    E-stop fault, the operator's end, a signal, or a lost link (the server's heartbeat:
    :class:`~exoleg.runtime.link.LoopLink`) -- then nobody could stop it from the page.
    ``cpus``: the CPUs the server had before it kept off the loop's
    (:func:`keep_off_loop_cpu`). ``child_path``: the fitted child's ``child.toml`` (the
    simulated child, on a simulated device); ``device``: the device folder (None:
    the shipped device)."""
    from exoleg.runtime.session import run

    def session(leg: Any, child: Any) -> None:
        run(backend, duration, folder, leg=leg, body_mass=body_mass, arm=arm,
            interface=interface, link=link, child=child, channel=channel, device=device)

    _in_own_process(link, folder, cpus, leg_path, child_path, session)


def _identify_process(link: LoopLink, backend: str, interface: str | None, plan: float,
                      folder: str, leg_path: str | None, arm: bool, cpus: set[int] | None,
                      child_path: str | None = None, channel: str = "exoleg",
                      device: str | None = None) -> None:
    """An identification's own process (:func:`exoleg.identify.device.identify_device`
    through the operator's link): the session in ``folder``, the identified leg and its
    report in ``folder``/:data:`IDENTIFIED`; ``plan``: its length, s."""
    from exoleg.identify.device import identify_device
    from exoleg.plots.identify import identify_figure

    def identification(leg: Any, child: Any) -> None:
        identify_device(backend, Path(folder) / IDENTIFIED, leg=leg, child=child,
                        duration=plan, interface=interface, link=link, arm=arm,
                        session=folder, channel=channel, figure=identify_figure,
                        device=device)

    _in_own_process(link, folder, cpus, leg_path, child_path, identification)


def _in_own_process(link: LoopLink, folder: str, cpus: set[int] | None, leg_path: str | None,
                    child_path: str | None, work: Any) -> None:
    """What a session's process does around its ``work(leg, child)``: back on the
    server's CPUs (``cpus``), the leg and child read from their files, and any failure
    said in ``failed.json`` (the Sessions page shows it; the torque is off either way)
    with the link told the loop ended."""
    import exoleg

    if cpus:
        with contextlib.suppress(AttributeError, OSError):
            os.sched_setaffinity(0, cpus)
    try:
        from exoleg.child.model import ChildModel

        work(exoleg.load_leg(leg_path) if leg_path else None,
             ChildModel.load(child_path) if child_path else None)
    except BaseException as e:  # said on the Sessions page; the torque is off either way
        write_json(Path(folder) / "failed.json",
                   {"error": f"{type(e).__name__}: {e}", "time": time.time()})
        link.loop_ended()
