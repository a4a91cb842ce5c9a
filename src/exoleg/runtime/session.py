"""``exoleg run`` and ``exoleg log summary``: a session on a backend, its log, its report."""

from __future__ import annotations

import math
import threading
import time
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from exoleg import checks as _check
from exoleg.entry import CONTROLLERS, DEFAULT_BODY_MASS, WALKING_CONTROLLERS
from exoleg.errors import ParameterError
from exoleg.runtime.device_lock import device_name, hold_device, let_go
from exoleg.runtime.loop import (
    LOG_HEAD,
    LOG_TAIL,
    OVERRUN_S,
    REFERENCE_PLAYED,
    Device,
    SessionResult,
    run_session,
)
from exoleg.session_log import (
    MAX_LOSS_TICKS,
    SessionLog,
    check_records,
    check_session,
    read_log,
)

if TYPE_CHECKING:
    from exoleg.system.config import DeviceConfig

BACKENDS = ("sim", "canopen", "ethercat")
#: the --interface that puts simulated nodes on the bus (hardware in the loop)
SIMULATED_BUS = {"canopen": "virtual", "ethercat": "fake"}
#: how long the master waits for every node's answer before it is a fault, s: on a real
#: bus (five 1 kHz cycles), and with simulated nodes, which are threads of this process
#: (a stock kernel stalled even a SCHED_FIFO thread here ~5.5 ms with the CPUs busy;
#: 10 runs of 10 s of the virtual CAN bus with 3 spinning processes on the 2 CPUs: at
#: 5 ms 2 lost a node's answer, at 20 ms none)
BUS_TIMEOUT_S = 5e-3
SIMULATED_BUS_TIMEOUT_S = 20e-3
#: The environment variable that sets the loop-overrun limit on a simulated device, ms
#: (the sim backend, simulated nodes: their world steps with the ticks, so a late tick
#: holds no torque stale there); for machines whose host stalls a process for longer than
#: the device's limit (the test suite on shared VMs: tests/conftest.py). Simulated nodes
#: on a virtual bus then wait as long for each other's answers, unless a bus timeout is
#: given (their threads stall with the process: a 27 ms stall lost a node's answer at the
#: 20 ms default with the suite on both CPUs). A real device always keeps
#: :data:`~exoleg.runtime.loop.OVERRUN_S` and its bus timeout.
SIM_OVERRUN_ENV = "EXOLEG_SIM_OVERRUN_MS"
#: What it may be, ms.
SIM_OVERRUN_RANGE_MS = (1.0, 1000.0)


def simulated_overrun() -> float | None:
    """The loop-overrun limit :data:`SIM_OVERRUN_ENV` sets (s), or None when unset; a
    value that is not a number within :data:`SIM_OVERRUN_RANGE_MS` is a ParameterError
    naming it."""
    import os

    raw = os.environ.get(SIM_OVERRUN_ENV)
    if raw is None:
        return None
    try:
        ms = float(raw)
    except ValueError:
        raise ParameterError("environment", SIM_OVERRUN_ENV,
                             f"{raw!r} is not a number of ms") from None
    lo, hi = SIM_OVERRUN_RANGE_MS
    return _check.within("environment", SIM_OVERRUN_ENV, ms, lo, hi, "ms") / 1e3


def simulated(backend: str, interface: str | None = None) -> bool:
    """Whether a simulated device answers: the sim backend, or simulated nodes on a bus
    (:data:`SIMULATED_BUS`, the default interface). Only there is the child simulated."""
    return backend == "sim" or (interface or SIMULATED_BUS[backend]) == SIMULATED_BUS[backend]


def check_options(backend: str, interface: str | None = None, arm: bool = False,
                  walk_after: float | None = None, bus_timeout: float | None = None,
                  overrun: float | None = None, controller: str = "walk",
                  link: Any = None, plan: bool = False) -> None:
    """Refuses (ParameterError) what :func:`run` refuses before it touches a bus: an
    unknown backend or controller, arming at the start on a real device (there the
    operator arms, not a command line), walking without arming, a bus timeout outside
    0.1 ms to the overrun limit, an operator interface for a controller other than the
    walking one (its gains and pages are the walking controller's) unless it follows
    identification's ``plan``."""
    if backend not in BACKENDS:
        raise ParameterError("exoleg run", "--backend", f"unknown {backend!r} (allowed: "
                             + ", ".join(BACKENDS) + ")")
    if controller not in CONTROLLERS:
        if ":" not in controller:
            raise ParameterError("exoleg run", "--controller", f"unknown {controller!r} "
                                 "(allowed: " + ", ".join(CONTROLLERS) + ", or FILE.py:NAME "
                                 "or MODULE:NAME for a law of your own)")
        from exoleg.control.tracking import law_factory

        law_factory(controller)  # a law of one's own: found, before a bus is touched
    if arm and not simulated(backend, interface):
        raise ParameterError("exoleg run", "--arm", "only on the sim backend or simulated "
                             "nodes (canopen --interface virtual, ethercat --interface "
                             "fake): on a real device the operator arms")
    overrun = OVERRUN_S if overrun is None else overrun
    if bus_timeout is not None and not 1e-4 <= bus_timeout <= overrun:
        raise ParameterError("exoleg run", "--bus-timeout",
                             f"{bus_timeout * 1e3:g} ms (allowed 0.1 ms to the overrun limit, "
                             f"{overrun * 1e3:g} ms)")
    if walk_after is not None and not arm:
        raise ParameterError("exoleg run", "--walk-after", "needs --arm (no motion without "
                             "arming)")
    if link is not None and controller not in WALKING_CONTROLLERS and not plan:
        raise ParameterError("exoleg run", "--hmi", f"the operator interface runs the "
                             f"walking controller, not {controller!r} (but for "
                             "identification's plan)")


#: the files that make a recorded session (a folder holding any of them holds one)
RECORD_FILES = ("session.log", "run.json", "failed.json")
#: the files of a session's folder an export must never write over
SESSION_FILES = (*RECORD_FILES, "control.log", "child.json", "leg.toml", "figures.json")
LOCK_FILE = ".exoleg-run.lock"


def check_folder(out: str | Path) -> Path:
    """The session folder ``out``, made if missing; a ParameterError when it holds a
    recorded session (never written over: :data:`RECORD_FILES`) or cannot be written."""
    from exoleg.io import _writable_folder

    folder = _writable_folder(Path(out))
    held = [n for n in RECORD_FILES if (folder / n).exists()]
    if held:
        raise ParameterError("exoleg run", "--out", f"{folder} holds a recorded session "
                             f"({', '.join(held)}): never written over; name a new folder "
                             "(nothing was changed)")
    return folder


def claim_folder(out: str | Path) -> tuple[Path, int]:
    """:func:`check_folder`, then hold the folder for this run: an exclusive lock on its
    :data:`LOCK_FILE` (released when the process ends, however it ends), which a second
    run into the same folder is refused. Returns (folder, the lock's descriptor: close
    it to release)."""
    import fcntl
    import os

    folder = check_folder(out)
    fd = os.open(folder / LOCK_FILE, os.O_RDWR | os.O_CREAT, 0o644)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        holder = os.read(fd, 64).decode(errors="replace").strip() or "?"
        os.close(fd)
        raise ParameterError("exoleg run", "--out", f"{folder} is in use by another run "
                             f"(process {holder}); name a new folder") from None
    os.ftruncate(fd, 0)
    os.write(fd, str(os.getpid()).encode())
    try:
        check_folder(folder)  # a run that ended between the check and the lock
    except BaseException:
        os.close(fd)
        raise
    return folder, fd


def open_device(backend: str, config: DeviceConfig, sim: Any, period: float,
                interface: str | None, channel: str, bus_timeout: float | None,
                inject: Any) -> tuple[Device, Any, float | None]:
    """The device a session drives, configured (:meth:`Device.configure` against the
    safety limits of ``config``): the simulated device ``sim`` itself, or the drive
    master of the bus for ``config``'s actuators with, on the bus's simulated interface,
    the simulated nodes answering from ``sim`` (returned as the rig). Returns (device,
    rig or None, the bus timeout in force)."""
    if backend == "sim":
        sim.configure(config.safety)
        return sim, None, None
    interface = interface or SIMULATED_BUS[backend]
    if bus_timeout is None:
        bus_timeout = SIMULATED_BUS_TIMEOUT_S if sim is not None else BUS_TIMEOUT_S
    if sim is not None:  # hardware in the loop: the simulated nodes answer
        sim.warm_up()
    acts = config.actuators
    rig: Any = None
    master: Any  # makes the bus's master (after the rig is on the bus)
    if backend == "canopen":
        from exoleg.hw.canopen_backend import CanopenBackend
        from exoleg.hw.canopen_sim import SimulatedRig

        rig = SimulatedRig(sim, interface, channel) if sim is not None else None
        master = lambda: CanopenBackend(acts, period, interface, channel,  # noqa: E731
                                        bus_timeout)
    else:
        from exoleg.hw.ethercat_backend import EthercatBackend
        from exoleg.hw.ethercat_sim import SimulatedSegment

        rig = SimulatedSegment(sim) if sim is not None else None
        master = lambda: EthercatBackend(acts, period, interface,  # noqa: E731
                                         master=rig, timeout=bus_timeout)
    if inject is not None and rig is not None:
        inject(-1, rig)  # a fault before the start (misconfiguration, offsets)
    b: Any = None
    try:
        b = master()
        b.configure(config.safety)
    except BaseException:
        if b is not None:
            b.deactivate()
        if rig is not None:
            rig.close()
        raise
    return b, rig, bus_timeout


def run(backend: str, duration: float, out: str | Path, period: float = 1e-3,
        arm: bool = False, walk_after: float | None = None, leg: Any = None,
        body_mass: float = DEFAULT_BODY_MASS, seed: int = 0, realtime: bool = True,
        interface: str | None = None, channel: str = "exoleg",
        inject: Any = None, link: Any = None, bus_timeout: float | None = None,
        overrun: float | None = None, controller: str = "walk", child: Any = None,
        reference: Any = None, step: float = 0.0, model: Any = None,
        device: str | Path | None = None, compiled: bool = True,
        expected_stride: float | None = None) -> tuple[SessionResult, Path]:
    """One session: the device (``backend``) under ``controller`` (the walking hierarchy,
    or one of the paper's laws on the paper's scenario, as
    :func:`~exoleg.system.build.build` makes them from ``device``, a device folder whose
    files replace the shipped ones) for
    ``duration`` s, logged to ``out``/session.log. On ``sim`` the operator's arming may
    be given here (``arm``), and walking from ``walk_after`` s. ``link``: a
    :class:`~exoleg.runtime.link.LoopLink` to the operator's side (the HMI and its
    control API, in another process): the loop publishes to it at 100 Hz and takes its
    commands. ``interface``: the canopen or ethercat backend's (default
    :data:`SIMULATED_BUS`: simulated nodes). ``bus_timeout``: how long the master waits
    for every node's answer before it is a fault (s; default :data:`BUS_TIMEOUT_S`, or
    :data:`SIMULATED_BUS_TIMEOUT_S` on simulated nodes); ``overrun``: how late a tick may
    start before it is a fault (s; default :data:`~exoleg.runtime.loop.OVERRUN_S`).
    ``out`` must hold no recorded session and no other run (:func:`claim_folder`): a
    session is never written over. ``child``: the simulated
    child (:class:`~exoleg.child.model.ChildModel`) on a simulated device; ``reference``:
    what a law other than the walking hierarchy follows (default the paper's scenario);
    ``step``: on a simulated device, the child on a step that high (m), the leg hanging
    (:meth:`~exoleg.world.device.SimulatedDevice.of`); ``model``: the leg a law is given, when it
    is not the one a simulated device carries (``leg``: the truth identification
    measures). ``compiled``: the simulated device under the walking controller ticks in
    compiled code off the interpreter lock (:mod:`exoleg.runtime.ticker`); False: from
    Python (:func:`~exoleg.runtime.loop.run_session`), as every other device and law
    does. ``expected_stride``: the stride the walking controller expects until it has
    measured the child's (s; the child's own cadence, their last session's; default the
    planned 1.1 s, :func:`~exoleg.system.build.build`'s)."""
    import os

    if overrun is None and simulated(backend, interface):
        overrun = simulated_overrun()
        if overrun is not None and bus_timeout is None and backend != "sim":
            # a host stalling the loop stalls the nodes' threads too; a lost answer is
            # held (exoleg.hw.master.LOSS_RUN in a row a fault), so its wait must leave
            # the run of them within the overrun limit
            from exoleg.hw.master import LOSS_RUN

            bus_timeout = overrun / (LOSS_RUN + 1)
    overrun = OVERRUN_S if overrun is None else overrun
    check_options(backend, interface, arm, walk_after, bus_timeout, overrun, controller,
                  link, plan=reference is not None)
    if walk_after is not None and walk_after >= duration:
        raise ParameterError("exoleg run", "--walk-after", f"{walk_after:g} s is not before "
                             f"the session's end ({duration:g} s): the walk would never come")
    if controller == "transparent" and child is None and simulated(backend, interface):
        raise ParameterError("exoleg run", "--controller", "transparent leaves the leg to "
                             "the child: give --child on a simulated device (a passive leg "
                             "in a transparent device falls)")
    folder, lock = claim_folder(out)
    held = None
    try:
        # a real device: held by this process alone, or refused before the bus is touched
        if not simulated(backend, interface):
            held = hold_device(device_name(backend, interface, channel))
        return _run(backend, duration, folder, period, arm, walk_after, leg, body_mass,
                    seed, realtime, interface, channel, inject, link, bus_timeout, overrun,
                    controller, child, reference, step, model, device, compiled,
                    expected_stride)
    finally:
        let_go(held)
        os.close(lock)


def _run(backend: str, duration: float, folder: Path, period: float, arm: bool,
         walk_after: float | None, leg: Any, body_mass: float, seed: int, realtime: bool,
         interface: str | None, channel: str, inject: Any, link: Any,
         bus_timeout: float | None, overrun: float, controller: str, child: Any = None,
         reference: Any = None, step: float = 0.0, model: Any = None,
         device_folder: str | Path | None = None, compiled: bool = True,
         expected_stride: float | None = None) -> tuple[SessionResult, Path]:
    """:func:`run` in the folder it holds."""
    import exoleg
    from exoleg.control.gears import law_bounds
    from exoleg.control.hierarchy import WalkController
    from exoleg.io import write_json
    from exoleg.runtime.sim_backend import SimBackend
    from exoleg.runtime.ticker import run_compiled
    from exoleg.system.build import build
    from exoleg.system.config import DeviceConfig
    from exoleg.tick import WALKING_MODES, Command

    leg = leg if leg is not None else exoleg.paper_leg()
    config = DeviceConfig.load(device_folder, control_dt=period)
    # a simulated device only where it is what answers: on sim, or behind simulated nodes
    system = build(config, leg, body_mass, controller,
                   simulated=simulated(backend, interface), child=child, model=model,
                   step=step, reference=reference, expected_stride=expected_stride)
    ctl = system.controller
    # the stride the walking controller expects before it has measured the child's
    expected = float(ctl.d[0]["expected_stride"]) if isinstance(ctl, WalkController) else None
    sim = (None if system.device is None
           else SimBackend(system.device, period, seed=seed, controller=ctl))
    before = set(threading.enumerate())
    b, rig, bus_timeout = open_device(backend, config, sim, period, interface, channel,
                                      bus_timeout, inject)
    # the bus's threads: receivers, simulated nodes
    io_threads = [t for t in threading.enumerate() if t not in before]
    try:
        path = folder / "session.log"
        import shutil

        need = (duration / period) * 8 * (len(LOG_HEAD) + len(b.columns) + len(LOG_TAIL))
        free = shutil.disk_usage(folder).free
        if need > 0.9 * free:
            raise ParameterError("exoleg run", "--duration",
                                 f"{duration:g} s of log needs {need / 2**30:.3g} GiB; "
                                 f"{free / 2**30:.3g} GiB is free in {folder}")
    except BaseException:
        b.deactivate()
        if rig is not None:
            rig.close()
        raise
    started = time.time()
    log = SessionLog(path, LOG_HEAD + b.columns + LOG_TAIL,
                     {"period": period, "backend": backend, "max_loss_ticks": MAX_LOSS_TICKS,
                      "leg": leg.name, "body_mass": body_mass,
                      "child": None if child is None else child.name,
                      "started": started, "controller": controller,
                      "device": config.summary(), "expected_stride_s": expected,
                      "interface": None if rig is None and backend == "sim" else
                      (interface or SIMULATED_BUS[backend])})
    commands: dict[int, int] = {}
    if arm:
        commands[0] = int(Command.ARM)
    if walk_after is not None:
        commands[max(1, int(round(walk_after / period)))] = int(Command.WALK)

    # a reference with an end (identification's plan) ends the session once played
    played = getattr(reference, "duration", None)

    def on_tick(k: int, out: dict[str, Any], sensors: dict[str, Any], late: float
                ) -> int | None:
        if inject is not None:
            inject(k, rig)
        if played is not None and getattr(ctl, "clock", 0.0) >= played:
            return REFERENCE_PLAYED
        if link is None:
            return None
        # 100 Hz to the operator's side: enough for a person, cheap for the loop
        link.loop_tick(k, k * period, out, sensors, late, period, publish=k % 10 == 0)
        cmd, change = link.loop_poll()
        if change is not None and tunable:  # (the web side refuses any other)
            ctl.set_gains(change)
            link.loop_gains(ctl.gains_now())
        return cmd

    def scenery(out: dict[str, Any]) -> None:
        # the simulated world (the treadmill and the other leg) follows the child's
        # walking: set before the drives' command acts on it
        if sim is not None:
            sim.walking = out["mode"] in WALKING_MODES

    # the page's gains are the walking controller's: another law (identification's plan)
    # publishes none, and the web side refuses a change
    tunable = controller in WALKING_CONTROLLERS
    if link is not None and tunable:  # the transparent law's bounds from its gears' modes
        link.loop_gains(ctl.gains_now(), law_bounds(leg, config.actuators,
                                                    config.transparency, period))
    try:
        if compiled and b is sim and isinstance(ctl, WalkController) and inject is None:
            res = run_compiled(b, ctl, duration, log, commands, realtime, link, tunable,
                               overrun)
        else:
            res = run_session(b, ctl, duration, period, log, commands, realtime=realtime,
                              on_tick=on_tick, overrun=overrun, io_threads=io_threads,
                              scenery=scenery)
    finally:
        if link is not None:
            link.loop_ended()
        b.deactivate()
        if rig is not None:
            rig.close()
    summary = {"backend": backend, "controller": controller, "device": config.summary(),
               "started": started, "expected_stride_s": expected,
               "period": period, "duration_s": res.ticks * period, "leg": leg.name,
               "ticks": res.ticks, "stopped_by": res.stopped_by,
               "bus_timeout_ms": None if bus_timeout is None else bus_timeout * 1e3,
               "overrun_ms": overrun * 1e3,
               "timing_us": res.timing, "realtime": res.realtime,
               **({"process_data": b.pdo_counts()} if hasattr(b, "pdo_counts") else {}),
               "log": str(path), "max_loss_ticks_on_a_crash": MAX_LOSS_TICKS}
    write_json(folder / "run.json", summary)
    _keep_figures(folder)
    return res, path


def _keep_figures(folder: Path) -> None:
    """The session's figures as a clinician reads them, computed once as it ends and
    kept beside its records (``figures.json``,
    :func:`exoleg.runtime.figures.session_figures`); a log they cannot be computed from
    keeps none (the session's own records are what counts)."""
    from exoleg.errors import ExolegError
    from exoleg.io import write_json
    from exoleg.runtime.figures import session_figures

    try:
        figures = session_figures(folder)
    except (ExolegError, ValueError):  # e.g. a session cut before its first tick
        return
    write_json(folder / "figures.json", figures)


def summarize(path: str | Path) -> dict[str, Any]:
    """What a session log holds: length, modes, faults, events, timing, tail dropped, and
    per joint the safety layer's hottest winding estimate (degC), its largest gear torque
    estimate (N m) and the ticks a gear was beyond its momentary peak (a log from before
    these columns: None), and the cuffs' torque, RMS and peak (N m) and RMS per kg (None
    where the device does not measure it)."""
    from exoleg.control.gait_phase import Event
    from exoleg.control.safety import Limited

    header, cols, cut = read_log(path)
    check_session(path, header)
    check_records(path, cols)
    n = len(cols["t"])
    period = float(header.get("period", 1e-3))
    late = cols["late"][1:] * 1e6 if n > 1 else np.zeros(0)
    modes = {int(m): int((cols["mode"] == m).sum()) for m in np.unique(cols["mode"])}
    status = cols["safety_status"].astype(np.int64)
    faulted = np.nonzero(status & Limited.FAULT)[0]
    return {"ticks": n, "duration_s": n * period, "period_s": period,
            "backend": header.get("backend", "?"), "leg": header.get("leg", "?"),
            "ticks_per_mode": modes,
            "first_fault_s": float(cols["t"][faulted[0]]) if len(faulted) else None,
            "initial_contacts": int(((cols["events"].astype(np.int64) & Event.IC) > 0).sum()),
            "late_p50_us": float(np.percentile(late, 50)) if len(late) else 0.0,
            "late_p99_us": float(np.percentile(late, 99)) if len(late) else 0.0,
            "late_max_us": float(late.max()) if len(late) else 0.0,
            "missed_deadlines": int((late > period * 1e6).sum()),
            "cut_record_bytes": cut, **_motor_figures(cols, status),
            **_interaction_figures(cols, float(header.get("body_mass", np.nan))),
            **_support_figures(cols, status)}


def _support_figures(cols: dict[str, Any], status: Any) -> dict[str, Any]:
    """The support per stride (between the detected initial contacts,
    :func:`~exoleg.sim.metrics.support_by_stride`; None in a log from before its
    columns) and what the safety layer did (:func:`~exoleg.sim.metrics.safety_events`)."""
    from exoleg.control.gait_phase import Event
    from exoleg.params.records import JOINTS
    from exoleg.sim.metrics import safety_events, support_by_stride

    t = cols["t"]
    names = [f"support_level_{j}" for j in JOINTS]
    strikes = t[(cols["events"].astype(np.int64) & Event.IC) > 0]
    return {"support_by_stride": support_by_stride(t, np.stack([cols[n] for n in names],
                                                               axis=1), strikes)
            if all(n in cols for n in names) else None,
            "safety_events": safety_events(t, status)}


def _interaction_figures(cols: dict[str, Any], body_mass: float) -> dict[str, Any]:
    """The cuffs' torque over a session, per joint
    (:func:`~exoleg.sim.metrics.interaction_figures`): RMS and peak (N m) and RMS per kg
    of body mass; None where the device did not measure it (no column, or NaN: the buses'
    drives)."""
    from exoleg.params.records import JOINTS
    from exoleg.sim.metrics import interaction_figures

    names = [f"interaction_{j}" for j in JOINTS]
    figs = (interaction_figures(np.stack([cols[n] for n in names], axis=1), body_mass)
            if all(n in cols for n in names) else [])
    if not figs or any(not math.isfinite(f["rms_Nm"]) for f in figs):
        return {"interaction_rms_Nm": None, "interaction_peak_Nm": None,
                "interaction_rms_Nm_per_kg": None}
    by = {f["joint"]: f for f in figs}
    return {"interaction_rms_Nm": {j: f["rms_Nm"] for j, f in by.items()},
            "interaction_peak_Nm": {j: f["peak_Nm"] for j, f in by.items()},
            "interaction_rms_Nm_per_kg": {j: f["rms_Nm_per_kg"] for j, f in by.items()}
            if body_mass > 0 else None}


def _motor_figures(cols: dict[str, Any], status: Any) -> dict[str, Any]:
    """The safety layer's motor and gear estimates over a session, per joint."""
    from exoleg.control.safety import Limited
    from exoleg.params.records import JOINTS

    def per_joint(prefix: str, f: Any) -> dict[str, Any] | None:
        names = [f"{prefix}_{j}" for j in JOINTS]
        if not all(n in cols for n in names) or not len(status):
            return None
        return {j: f(cols[n]) for j, n in zip(JOINTS, names, strict=True)}

    over = (status & Limited.GEAR_PEAK) > 0
    return {"winding_max_C": per_joint("winding_temp", lambda c: float(c.max())),
            "gear_peak_Nm": per_joint("gear_torque", lambda c: float(np.abs(c).max())),
            "ticks_gear_beyond_momentary_peak": int(over.sum())
            if "gear_torque_hip" in cols else None}


def to_table(path: str | Path) -> Any:
    """The log as an Arrow table (the same series format as ``exoleg simulate``)."""
    import pyarrow as pa

    _, cols, _ = read_log(path)
    return pa.table(cols)
