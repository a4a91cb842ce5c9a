"""A session's own process under ``exoleg hmi``: the loop, or an identification, each in
a process of its own started from the *Control* page, talking to the server through a
:class:`~exoleg.runtime.link.LoopLink`."""

from __future__ import annotations

import contextlib
import multiprocessing as mp
import os
import threading
import time
from pathlib import Path
from typing import Any

from exoleg.io import write_json
from exoleg.runtime.link import LoopLink

#: an identification session's own folder for what it identified
IDENTIFIED = "identified"


class SessionProcesses:
    """How the console starts a session's (or an identification's) process.

    Afresh (``spawn``) until a server of processes is ready, forked from it after. A
    process started afresh imports the loop, sets up numba's compiler target and loads
    the compiled tick before its first tick: from Start to the device standing on the
    page, 1.1-1.3 s. The server of processes (multiprocessing's ``forkserver``) does that
    once (:mod:`exoleg.hmi._warm`); from it, 0.27-0.34 s (``benchmarks/bench_hmi.py``).
    The server calls :meth:`warm` once the first session ticks: the server of processes
    loads beside that session, not in the way of its start, and a console whose sessions
    never start spends nothing on it. A Start never waits for it (after an upgrade whose
    compiled cache is stale it compiles for a minute): until it is ready, sessions start
    afresh. It is a fresh interpreter of its own, not the web server: nothing of the
    server's threads, sockets or event loop is in a session's process. Where the OS has
    no fork, every process starts afresh."""

    def __init__(self) -> None:
        self.ready = threading.Event()
        self.warming: threading.Thread | None = None

    def context(self) -> Any:
        """The multiprocessing context to start the next session's process with."""
        return mp.get_context("forkserver" if self.ready.is_set() else "spawn")

    def warm(self) -> None:
        """Start the server of processes, in the background (once; where the OS has
        fork)."""
        if self.warming is None and "forkserver" in mp.get_all_start_methods():
            self.warming = threading.Thread(target=self._warm, name="exoleg-forkserver",
                                            daemon=True)
            self.warming.start()

    def _warm(self) -> None:
        ctx = mp.get_context("forkserver")
        ctx.set_forkserver_preload(["exoleg.hmi._warm"])
        with contextlib.suppress(OSError):  # not started: sessions go on starting afresh
            first = ctx.Process(target=os.getpid, name="exoleg-forkserver-ready")
            first.start()  # returns once the server has loaded the loop and forked
            self.ready.set()
            first.join()  # (its exit code may be read by another thread's start: unused)


def _session_process(link: LoopLink, backend: str, interface: str | None, duration: float,
                     folder: str, leg_path: str | None, body_mass: float, arm: bool,
                     cpus: set[int] | None, child_path: str | None = None,
                     channel: str = "exoleg", device: str | None = None,
                     expected_stride: float | None = None) -> None:
    """A session's own process (``exoleg hmi``): runs the loop until its duration, an
    E-stop fault, the operator's end, a signal, or a lost link (the server's heartbeat:
    :class:`~exoleg.runtime.link.LoopLink`) -- then nobody could stop it from the page.
    ``cpus``: the CPUs the server had before it kept off the loop's
    (:func:`keep_off_loop_cpu`). ``child_path``: the fitted child's ``child.toml`` (the
    simulated child, on a simulated device); ``device``: the device folder (None:
    the shipped device); ``expected_stride``: the child's own stride, s (their last
    session's: :func:`~exoleg.hmi.history.expected_stride`; None: the planned one)."""
    from exoleg.runtime.session import run

    def session(leg: Any, child: Any) -> None:
        run(backend, duration, folder, leg=leg, body_mass=body_mass, arm=arm,
            interface=interface, link=link, child=child, channel=channel, device=device,
            expected_stride=expected_stride)

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
