"""The loop: a session of sensors -> controller -> drives at a fixed rate.

The period is kept by :class:`~exoleg.runtime.clock.RateClock`. What CPython on a stock
kernel can promise is a good median and p99, not a bound: the garbage collector, the
scheduler and page faults give a tail of milliseconds. The session freezes the heap (no
collection in the loop) and asks for SCHED_FIFO where permitted, for the bus's threads
too, and for an isolated CPU where the kernel keeps one
(:func:`~exoleg.runtime.realtime.realtime_settings`). The simulated device under the
walking controller ticks off the interpreter instead (:mod:`exoleg.runtime.ticker`: the
same ticks, compiled, in a thread of their own); hard real time needs a real-time
kernel beside that. The device's readings are watched for what the safety layer cannot
see in the values (:class:`~exoleg.runtime.watch.SensorWatch`).

:func:`run_session` runs one session on a device (:class:`Device`: ``read``, ``write``)
and a controller (:class:`~exoleg.control.contract.Controller`: ``update(sensors,
command, t)`` -> the output record's fields): read -> update -> write, the same
controller objects ``exoleg simulate`` runs, on every device. A controller exception, a
non-finite command or SIGINT/SIGTERM takes the torque off at once, the reason goes to
the log's summary, and the log closes; so does any other failure in the tick (the bus,
the log's disk, the operator's link).
"""

from __future__ import annotations

import contextlib
import gc
import signal
import threading
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np
from numpy.typing import NDArray

from exoleg.control.safety import fault_event
from exoleg.runtime.clock import RateClock
from exoleg.runtime.realtime import realtime_settings, saved_scheduling
from exoleg.runtime.watch import SensorWatch
from exoleg.session_log import SessionLog
from exoleg.tick import (
    ARMED_MODES,
    OUTPUT,
    WALKING_MODES,
    Command,
    Controller,
    Mode,
    output_columns,
)

F64 = NDArray[np.float64]


#: A tick later than this, s, is a loop overrun: the drives have held a stale torque for
#: that long, so the torque goes off. 50 ms: four times the worst stall a stock kernel on
#: this shared 2-core VM gave (12.4 ms in ``benchmarks/bench_runtime.py``, a few stalls of
#: 2-12 ms a minute), half a drive's own watchdog (EtherCAT's sync manager default,
#: 100 ms). On a real-time kernel it can be tightened (``run(..., overrun=)``).
OVERRUN_S = 0.05
#: Overruns as data (ros2_control's ``overruns.manage``): the controller is given the
#: fixed period and every tick's lateness is logged; one tick later than a period is
#: tolerated, this many in a row are a controlled stop (the loop cannot keep time), and
#: one later than :data:`OVERRUN_S` takes the torque off at once.
LATE_RUN_TICKS = 10


def late_run_ticks(overrun: float) -> int:
    """How many ticks in a row later than a period are a controlled stop, under the
    overrun limit ``overrun`` s: :data:`LATE_RUN_TICKS` at :data:`OVERRUN_S`, as many
    times more as a simulated device's limit is relaxed (the test suite's host)."""
    return max(LATE_RUN_TICKS, int(round(LATE_RUN_TICKS * overrun / OVERRUN_S)))


def stood_text(end: str, mode: int, seconds: float) -> str:
    """A session's end that came to a controlled stop, said (before ': torque off')."""
    return f"{end}, after a controlled stop to {Mode(mode).name} in {seconds:.2f} s"


def not_stood_text(end: str) -> str:
    """A session's end whose controlled stop did not stand in time, said."""
    return f"{end}: the controlled stop did not stand within {STOP_GRACE_S:g} s: torque off"


def overrun_text(tick: int, late: float, overrun: float) -> str:
    """A loop overrun, said."""
    return (f"loop overrun: tick {tick} started {late * 1e3:.1f} ms late (limit "
            f"{overrun * 1e3:g} ms): torque off")


def late_run_text(ticks: int) -> str:
    """How a session ended by a run of late ticks is said."""
    return f"the loop fell behind: {ticks} ticks in a row later than a period"


class Device(Protocol):
    """A device the loop drives, simulated or on a bus: a lifecycle component in the
    manner of ros2_control's system interface. ``configure`` brings it up and checks it
    (the drives' identity, mode and position against the range of motion); each tick
    ``read`` gives its state interfaces (the :data:`~exoleg.control.contract.SENSORS`
    fields, plus ``fault`` when the device itself failed) and ``write`` takes its command
    interfaces (joint torques, N m, and whether the drives are enabled); ``safe`` is the
    quick stop (torque off now); ``deactivate`` releases it; ``warm_up`` compiles what
    its ticks run before the clock starts. ``columns`` name what ``record`` gives the
    session log each tick."""

    columns: list[str]

    def configure(self, limits: Any) -> list[str]: ...
    def warm_up(self) -> None: ...
    def read(self, t: float) -> dict[str, Any]: ...
    def write(self, tau: F64, enable: bool) -> None: ...
    def safe(self) -> None: ...
    def deactivate(self) -> None: ...
    def record(self) -> F64: ...


@dataclass
class SessionResult:
    ticks: int
    stopped_by: str
    timing: dict[str, float]
    realtime: list[str] = field(default_factory=list)


#: the log's columns around the device's own (:attr:`Device.columns`): the time and
#: lateness, then the controller's output record (its ``tau`` as ``u``: the command)
LOG_HEAD = ["t", "late"]
LOG_TAIL = ["u" + c[3:] if c.startswith("tau_") else c for c in output_columns()]


def _slots() -> list[tuple[str, int, int]]:
    """Each :data:`OUTPUT` field's place in :data:`LOG_TAIL`: (name, start, stop)."""
    out, k = [], 0
    for name in OUTPUT.names or ():
        n = int(np.prod(OUTPUT[name].shape)) if OUTPUT[name].shape else 1
        out.append((name, k, k + n))
        k += n
    return out


_SLOTS = _slots()


def output_row(out: dict[str, Any]) -> F64:
    """A controller's output (the :data:`~exoleg.control.contract.OUTPUT` fields) as the
    log's :data:`LOG_TAIL` values; a missing or misshapen field is a ValueError naming
    it."""
    row = np.empty(len(LOG_TAIL))
    for name, a, b in _SLOTS:
        try:
            row[a:b] = out[name]
        except KeyError:
            raise ValueError(f"the controller's output has no {name!r}") from None
        except (TypeError, ValueError) as e:
            raise ValueError(f"the controller's {name!r} is {out[name]!r}: {e}") from None
    return row


#: The longest a controlled stop at a session's end may take, s: the walking stop's wait
#: for the foot under the hip (1.5 strides, of up to the 1.75 x 1.1 s strides the detector
#: accepts) and its move to standing (0.8 s), with a second to spare.
STOP_GRACE_S = 5.0


#: what ``on_tick`` returns to end the session (torque off, log closed), and why
END_SESSION = -1
LINK_LOST = -2
REFERENCE_PLAYED = -3
ENDS = {END_SESSION: "the operator ended the session",
        LINK_LOST: "link lost: the operator interface's heartbeat stopped (nobody could "
                   "stop the device from a page)",
        REFERENCE_PLAYED: "the reference played to its end"}


def stop_on_signals(stop: list[str]) -> dict[int, Any]:
    """SIGINT and SIGTERM noted in ``stop`` (in the main thread, which alone gets them);
    returns the handlers they replaced, to put back."""
    def on_signal(signum: int, frame: object) -> None:
        stop.append(f"signal {signal.Signals(signum).name}")

    if threading.current_thread() is not threading.main_thread():
        return {}
    return {s: signal.signal(s, on_signal) for s in (signal.SIGINT, signal.SIGTERM)}


def run_session(backend: Device, controller: Controller, duration: float, period: float,
                log: SessionLog, commands: dict[int, int] | None = None,
                realtime: bool = True,
                on_tick: Callable[[int, dict[str, Any], dict[str, Any], float], int | None]
                | None = None, overrun: float = OVERRUN_S,
                io_threads: Sequence[threading.Thread] = (),
                scenery: Callable[[dict[str, Any]], None] | None = None) -> SessionResult:
    """Run ``duration`` s of ticks; ``commands``: tick -> operator command (arm, walk...).
    ``on_tick(k, out, sensors, late)`` may return a command for the next tick (the
    operator's way in), or :data:`END_SESSION` / :data:`LINK_LOST` /
    :data:`REFERENCE_PLAYED` (:data:`ENDS`). Every
    tick: read, update, log, write (the drives enabled in the armed modes). The end of
    the duration, the operator's end and a lost link are controlled stops while the child
    walks: the loop commands a stand, goes on until the supervisor stands (at most
    :data:`STOP_GRACE_S`), then takes the torque off; a signal, a fault or an E-stop is
    immediate. A tick later than ``overrun`` s takes the torque off and stops, a run of
    ticks later than a period (:func:`late_run_ticks`) is a controlled stop. With
    ``realtime``, the loop runs at SCHED_FIFO and the ``io_threads`` above it
    (:func:`realtime_settings`); this thread's scheduling is restored afterwards.
    ``scenery(out)``: a simulated world told each tick's output before the drives'
    command acts on it (the treadmill follows the supervisor's walking). Returns how it
    ended."""
    stop: list[str] = []
    backend.warm_up()  # compile before the clock starts
    controller.warm_up()
    old = stop_on_signals(stop)
    restore = saved_scheduling()
    rt = realtime_settings(io_threads, period) if realtime else []
    clock = RateClock(period)
    watch = SensorWatch(period)
    n = int(round(duration / period))
    limit = n  # ticks: a controlled stop at the end extends it by STOP_GRACE_S at most
    ending = ""  # why the session ends, while its controlled stop is under way
    k_ending = 0
    pending = dict(commands or {})
    zero = np.zeros(3)
    reason = "duration"
    gc.collect()
    gc.freeze()
    gc.disable()  # no collection pauses in the loop
    clock.start()
    k = -1
    late = 0.0
    late_run, late_limit = 0, late_run_ticks(overrun)  # ticks in a row later than a period
    latched = ""  # the first fault or E-stop the controller latched, and when
    try:
        while k + 1 < limit:
            k += 1
            t = k * period
            sensors = backend.read(t)
            fault = sensors.get("fault") or watch.check(sensors)
            if fault:  # the drives, the bus or the sensors: torque off, stop
                backend.safe()
                reason = f"device fault: {fault}"
                break
            command = pending.pop(k, 0)
            sensors["command"] = command
            try:
                out = controller.update(sensors, command, t)
                tau = np.asarray(out["tau"], dtype=float)
                if tau.shape != (3,) or not np.all(np.isfinite(tau)):
                    raise ValueError(f"controller gave {tau!r}")
                row = output_row(out)
            except Exception as e:  # the controller failed: torque off, stop
                backend.write(zero, False)
                backend.safe()
                reason = f"controller error: {type(e).__name__}: {e}"
                break
            if out["fault"] and not latched:  # how the session ends says it
                latched = f"after {fault_event(out['fault'], out['fault_joint'])} at {t:.3f} s"
            log.append(np.concatenate([[t, late], backend.record(), row]))
            if scenery is not None:
                scenery(out)
            # the drives follow the supervisor's arming
            backend.write(tau, out["mode"] in ARMED_MODES)
            end = "duration" if k == n - 1 else ""
            if late_run >= late_limit:
                end = late_run_text(late_limit)
            if on_tick is not None:
                cmd = on_tick(k, out, sensors, late)
                if cmd in ENDS:
                    end = ENDS[cmd]
                elif cmd:
                    j = k + 1
                    while j in pending:  # after the commands already set for a tick
                        j += 1
                    pending[j] = cmd
            walking = out["mode"] in WALKING_MODES
            if end and not ending and walking:  # a controlled stop first: stand, then off
                ending, k_ending = end, k
                pending[k + 1] = Command.STAND  # before anything else set for that tick
                limit = k + 1 + int(round(STOP_GRACE_S / period))
            elif ending and not walking:
                stop.append(stood_text(ending, out["mode"], (k - k_ending) * period))
            elif end and not ending and end != "duration":
                stop.append(end)
            if stop:
                backend.write(zero, False)
                backend.safe()
                reason = f"{stop[0]}: torque off"
                break
            late = clock.wait()
            late_run = late_run + 1 if late > period else 0
            if late > overrun:  # the drives held a stale torque too long
                backend.write(zero, False)
                backend.safe()
                reason = overrun_text(k + 1, late, overrun)
                break
        else:
            if ending:  # the stop did not stand in time: the torque goes off all the same
                backend.write(zero, False)
                backend.safe()
                reason = not_stood_text(ending)
    except BaseException as e:  # the bus, the log (disk full), the operator's link...
        with contextlib.suppress(Exception):  # the torque off first, whatever failed
            backend.write(zero, False)
        with contextlib.suppress(Exception):
            backend.safe()
        if not isinstance(e, Exception):
            raise
        reason = f"loop error: {type(e).__name__}: {e}: torque off"
    finally:
        if latched:
            reason = f"{reason} ({latched})"
        gc.enable()
        gc.unfreeze()
        for s, h in old.items():
            signal.signal(s, h)
        restore()
        log.close()
    return SessionResult(ticks=k + 1, stopped_by=reason, timing=clock.stats(), realtime=rt)
