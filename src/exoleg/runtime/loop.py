"""The fixed-rate loop and its timing, and a session: sensors -> controller -> drives.

:class:`RateClock` keeps the period on CPython: it sleeps until ``spin`` seconds before
each deadline and busy-waits the rest (a plain ``time.sleep`` wakes 80-115 us late on
this kind of machine; sleeping short and spinning brings the median to ~0), counts
every tick's lateness and the deadlines missed by more than a period. What CPython on a
stock kernel can promise is a good median and p99, not a bound: the garbage collector,
the scheduler and page faults give a tail of milliseconds. The session freezes the heap
(no collection in the loop) and asks for SCHED_FIFO where permitted, for the bus's
threads too, and for an isolated CPU where the kernel keeps one (:func:`realtime_settings`);
hard real time needs the loop on a real-time kernel, or the tick in C on an isolated
core, with this process above it as the operator's side.

:func:`run_session` runs one session on a device (:class:`Device`: ``read``, ``write``)
and a controller (:class:`~exoleg.control.contract.Controller`: ``update(sensors,
command, t)`` -> the output record's fields): read -> update -> write, the same
controller objects ``exoleg simulate`` runs, on every device. A controller exception, a
non-finite command or SIGINT/SIGTERM takes the torque off at once, the reason goes to
the log's summary, and the log closes;
so does any other failure in the tick (the bus, the log's disk, the operator's link).
"""

from __future__ import annotations

import contextlib
import gc
import os
import signal
import sys
import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np
from numpy.typing import NDArray

from exoleg.control.contract import ARMED_MODES, OUTPUT, output_columns
from exoleg.layout import flat
from exoleg.runtime.log import SessionLog

if TYPE_CHECKING:
    from exoleg.control.contract import Controller

F64 = NDArray[np.float64]


class RateClock:
    """Ticks every ``period`` s from the first :meth:`wait`; keeps each tick's lateness."""

    def __init__(self, period: float, spin: float = 2e-4, capacity: int = 1 << 20) -> None:
        self.period = float(period)
        self.spin = float(spin)
        self.late = np.zeros(capacity)
        self.n = 0
        self.next = 0.0

    def start(self) -> None:
        self.next = time.perf_counter() + self.period

    def wait(self) -> float:
        """Wait for the next deadline; returns how late it was reached (s)."""
        sleep = self.next - self.spin - time.perf_counter()
        if sleep > 0:
            time.sleep(sleep)
        while True:
            now = time.perf_counter()
            if now >= self.next:
                break
        late = now - self.next
        if self.n < len(self.late):
            self.late[self.n] = late
        self.n += 1
        self.next += self.period
        if late > self.period:  # missed: resynchronise instead of running to catch up
            self.next = now + self.period
        return late

    def stats(self) -> dict[str, float]:
        """Lateness p50/p99/p99.9/max (us) and deadlines missed by more than a period."""
        x = self.late[: min(self.n, len(self.late))] * 1e6
        if not len(x):
            return {"ticks": 0}
        return {"ticks": int(self.n), "p50_us": float(np.percentile(x, 50)),
                "p99_us": float(np.percentile(x, 99)),
                "p999_us": float(np.percentile(x, 99.9)), "max_us": float(x.max()),
                "missed": int((x > self.period * 1e6).sum())}


#: SCHED_FIFO priorities: the loop's thread, and the bus's threads above it (their
#: answer is what the loop waits for, as a kernel's interrupt threads sit above the
#: tasks they wake)
LOOP_PRIORITY = 10
IO_PRIORITY = 11


def isolated_cpus(path: str = "/sys/devices/system/cpu/isolated") -> set[int]:
    """The CPUs the kernel keeps for pinned tasks (``isolcpus=``); empty when none."""
    cpus: set[int] = set()
    try:
        for part in filter(None, Path(path).read_text().strip().split(",")):
            lo, _, hi = part.partition("-")
            cpus.update(range(int(lo), int(hi or lo) + 1))
    except (OSError, ValueError):  # no such file, or not a CPU list: nothing isolated
        return set()
    return cpus


def realtime_settings(io_threads: Sequence[threading.Thread] = (),
                      period: float = 1e-3) -> list[str]:
    """Ask for SCHED_FIFO for this thread where the OS permits, and pin it to an isolated
    CPU if the kernel keeps one; the ``io_threads`` (the bus's receivers, the simulated
    nodes) get SCHED_FIFO above it, and a thread waiting for the GIL asks for it after a
    quarter ``period`` instead of CPython's 5 ms. Returns what was done.

    Measured on this 2-core VM with both CPUs busy (3 spinning processes), 10 s of the
    virtual CAN bus at 1 kHz, 5 ms bus timeout: with the loop pinned to a shared CPU
    and the bus threads at normal priority, every run lost a drive's answer within
    0.1 s; bus threads raised and the GIL's interval cut, 3 runs in 5 still did (the
    pinned loop cannot leave the CPU when the kernel gives it to other tasks for
    milliseconds); unpinned as well, 2 in 10 -- a stock kernel still stalls even a
    SCHED_FIFO thread ~5.5 ms then, hence the simulated nodes' longer bus timeout
    (:data:`exoleg.runtime.session.SIMULATED_BUS_TIMEOUT_S`)."""
    done = []
    if io_threads:
        switch = min(sys.getswitchinterval(), period / 4)
        sys.setswitchinterval(switch)
        done.append(f"GIL switch interval {switch * 1e6:.0f} us")
    with contextlib.suppress(AttributeError, OSError):
        cpus = isolated_cpus() & os.sched_getaffinity(0)
        if cpus:
            os.sched_setaffinity(0, {max(cpus)})
            done.append(f"pinned to isolated CPU {max(cpus)}")
        else:
            done.append("not pinned (no isolated CPU)")
    with contextlib.suppress(AttributeError, OSError):
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(LOOP_PRIORITY))
        done.append(f"SCHED_FIFO priority {LOOP_PRIORITY}")
    raised = 0
    for t in io_threads:
        with contextlib.suppress(AttributeError, OSError, TypeError):
            os.sched_setscheduler(t.native_id, os.SCHED_FIFO,  # type: ignore[arg-type]
                                  os.sched_param(IO_PRIORITY))
            raised += 1
    if raised:
        done.append(f"{raised} bus threads SCHED_FIFO priority {IO_PRIORITY}")
    return done


def _saved_scheduling() -> Callable[[], None]:
    """What puts this thread's CPU affinity and scheduling policy, and the GIL's switch
    interval, back as they are now."""
    switch = sys.getswitchinterval()
    try:
        cpus, policy = os.sched_getaffinity(0), os.sched_getscheduler(0)
        param = os.sched_getparam(0)
    except (AttributeError, OSError):
        return lambda: sys.setswitchinterval(switch)

    def restore() -> None:
        sys.setswitchinterval(switch)
        with contextlib.suppress(OSError):
            os.sched_setscheduler(0, policy, param)
            os.sched_setaffinity(0, cpus)
    return restore


class Device(Protocol):
    """A device the loop drives, simulated or on a bus: a lifecycle component in the
    manner of ros2_control's system interface. ``configure`` brings it up and checks it
    (the drives' identity, mode and position against the range of motion); each tick
    ``read`` gives its state interfaces (the :data:`~exoleg.control.contract.SENSORS`
    fields, plus ``fault`` when the device itself failed) and ``write`` takes its command
    interfaces (joint torques, N m, and whether the drives are enabled); ``safe`` is the
    quick stop (torque off now); ``deactivate`` releases it. ``columns`` name what
    ``record`` gives the session log each tick."""

    columns: list[str]

    def configure(self, limits: Any) -> list[str]: ...
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


#: A sensor is frozen when the foot board's readings (four FSRs and the gyro, noisy in
#: every real sample) repeat bit for bit this long, s; a joint reading is implausible
#: when it moves more than this far in one tick, rad (0.1 rad in 1 ms is 5700 deg/s,
#: eight times the fastest joint of Table 2).
FROZEN_S = 0.25
JUMP_RAD = 0.1
#: A tick later than this, s, is a loop overrun: the drives have held a stale torque for
#: that long, so the torque goes off. 50 ms: four times the worst stall a stock kernel on
#: this shared 2-core VM gave (12.4 ms in ``benchmarks/bench_runtime.py``, a few stalls of
#: 2-12 ms a minute), half a drive's own watchdog (EtherCAT's sync manager default,
#: 100 ms). On a real-time kernel it can be tightened (``run(..., overrun=)``).
OVERRUN_S = 0.05


class SensorWatch:
    """Faults the safety layer cannot see in the values themselves: a frozen sensor and
    an implausible jump of a joint reading (a bad encoder frame, a wrong offset)."""

    def __init__(self, period: float) -> None:
        self.limit = max(1, int(round(FROZEN_S / period)))
        self.same = 0
        self.last: F64 | None = None
        self.q_last: F64 | None = None

    def check(self, sensors: dict[str, Any]) -> str:
        foot = np.concatenate([np.asarray(sensors["fsr"], dtype=float),
                               [float(sensors.get("gyro", 0.0))]])
        if self.last is not None and np.array_equal(foot, self.last):
            self.same += 1
            if self.same >= self.limit:
                return f"the foot board's readings froze for {self.same} ticks"
        else:
            self.same = 0
        self.last = foot
        q = np.asarray(sensors["q"], dtype=float)
        if self.q_last is not None:
            jump = np.abs(q - self.q_last)
            if np.any(jump > JUMP_RAD):
                i = int(np.argmax(jump))
                return (f"implausible joint reading: joint {i} moved {jump[i]:.3g} rad in "
                        f"one tick (at most {JUMP_RAD} rad)")
        self.q_last = q
        return ""


#: the log's columns around the device's own (:attr:`Device.columns`): the time and
#: lateness, then the controller's output record (its ``tau`` as ``u``: the command)
LOG_HEAD = ["t", "late"]
LOG_TAIL = ["u" + c[3:] if c.startswith("tau_") else c for c in output_columns()]


def output_row(out: dict[str, Any]) -> F64:
    """A controller's output (the :data:`~exoleg.control.contract.OUTPUT` fields) as the
    log's :data:`LOG_TAIL` values; a missing or misshapen field is a ValueError naming
    it."""
    rec = np.zeros(1, OUTPUT)
    for name in OUTPUT.names or ():
        if name not in out:
            raise ValueError(f"the controller's output has no {name!r}")
        try:
            rec[0][name] = out[name]
        except (TypeError, ValueError) as e:
            raise ValueError(f"the controller's {name!r} is {out[name]!r}: {e}") from None
    return flat(rec)[0]


#: what ``on_tick`` returns to end the session (torque off, log closed), and why
END_SESSION = -1
LINK_LOST = -2
ENDS = {END_SESSION: "the operator ended the session",
        LINK_LOST: "the operator interface's process is gone (nobody could stop it)"}


def run_session(backend: Device, controller: Controller, duration: float, period: float,
                log: SessionLog, commands: dict[int, int] | None = None,
                realtime: bool = True,
                on_tick: Callable[[int, dict[str, Any], dict[str, Any], float], int | None]
                | None = None, overrun: float = OVERRUN_S,
                io_threads: Sequence[threading.Thread] = (),
                scenery: Callable[[dict[str, Any]], None] | None = None) -> SessionResult:
    """Run ``duration`` s of ticks; ``commands``: tick -> operator command (arm, walk...).
    ``on_tick(k, out, sensors, late)`` may return a command for the next tick (the
    operator's way in), or :data:`END_SESSION` / :data:`LINK_LOST` (:data:`ENDS`). Every
    tick: read, update, log, write (the drives enabled in the armed modes). A tick later
    than ``overrun`` s takes the torque off and stops. With ``realtime``, the loop runs at
    SCHED_FIFO and the ``io_threads`` above it (:func:`realtime_settings`); this thread's scheduling is
    restored afterwards. ``scenery(out)``: a simulated world told each tick's output
    before the drives' command acts on it (the treadmill follows the supervisor's
    walking). Returns how it ended."""
    stop: list[str] = []

    def on_signal(signum: int, frame: object) -> None:
        stop.append(f"signal {signal.Signals(signum).name}")

    for part in (backend, controller):  # compile before the clock starts
        warm = getattr(part, "warm_up", None)
        if warm is not None:
            warm()
    main = threading.current_thread() is threading.main_thread()  # only it gets signals
    old = ({s: signal.signal(s, on_signal) for s in (signal.SIGINT, signal.SIGTERM)}
           if main else {})
    restore = _saved_scheduling()
    rt = realtime_settings(io_threads, period) if realtime else []
    clock = RateClock(period)
    watch = SensorWatch(period)
    n = int(round(duration / period))
    pending = dict(commands or {})
    zero = np.zeros(3)
    reason = "duration"
    gc.collect()
    gc.freeze()
    gc.disable()  # no collection pauses in the loop
    clock.start()
    k = 0
    late = 0.0
    try:
        for k in range(n):
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
            log.append(np.concatenate([[t, late], backend.record(), row]))
            if scenery is not None:
                scenery(out)
            # the drives follow the supervisor's arming
            backend.write(tau, out["mode"] in ARMED_MODES)
            if on_tick is not None:
                cmd = on_tick(k, out, sensors, late)
                if cmd in ENDS:
                    stop.append(ENDS[cmd])
                elif cmd:
                    j = k + 1
                    while j in pending:  # after the commands already set for a tick
                        j += 1
                    pending[j] = cmd
            if stop:
                backend.write(zero, False)
                backend.safe()
                reason = f"{stop[0]}: torque off"
                break
            late = clock.wait()
            if late > overrun:  # the drives held a stale torque too long
                backend.write(zero, False)
                backend.safe()
                reason = (f"loop overrun: tick {k + 1} started {late * 1e3:.1f} ms late "
                          f"(limit {overrun * 1e3:g} ms): torque off")
                break
    except BaseException as e:  # the bus, the log (disk full), the operator's link...
        with contextlib.suppress(Exception):  # the torque off first, whatever failed
            backend.write(zero, False)
        with contextlib.suppress(Exception):
            backend.safe()
        if not isinstance(e, Exception):
            raise
        reason = f"loop error: {type(e).__name__}: {e}: torque off"
    finally:
        gc.enable()
        gc.unfreeze()
        for s, h in old.items():
            signal.signal(s, h)
        restore()
        log.close()
    return SessionResult(ticks=k + 1, stopped_by=reason, timing=clock.stats(), realtime=rt)
