"""The tick off the interpreter: the simulated device's whole 1 kHz loop in compiled code.

:func:`run_ticks` keeps the period itself -- ``clock_nanosleep`` to an absolute deadline
on the monotonic clock, the last ``spin`` of it on ``clock_gettime`` -- and per tick
steps the simulated device under the drives' last command, reads it, watches the
readings (a frozen foot board, an implausible joint jump), takes the operator's command,
runs the walking controller's tick (supervisor, gait phase, impedance or transparency,
safety layer), writes the drives and appends the tick to a ring: every call numba code
that holds no interpreter lock (``nogil``) and allocates nothing. It runs in a thread of
its own at SCHED_FIFO (:class:`~exoleg.runtime.loop.Device` sessions on the simulated
device, :func:`~exoleg.runtime.loop.run_session`); Python stays on the outside -- it
drains the ring into the crash-safe log, serves the operator's link, draws the sensors'
noise ahead and asks for commands, gain changes and ends through a shared array, which the
tick polls (an E-stop before anything else). What it does per tick is the Python loop's
to the bit (``tests/test_realtime.py``); its shared arrays are written by one side and
read by the other, the index after the data (x86's stores are seen in order; the
clock's calls are opaque to the compiler, so no read is hoisted out of the loop).

Overruns are data (ros2_control's ``overruns.manage``): the controller is given the
fixed period, each tick's lateness goes in its record, a tick later than a period is
tolerated, a run of them (:func:`~exoleg.runtime.loop.late_run_ticks`) is a controlled
stop and one beyond the overrun limit takes the torque off (:class:`Stop`).
"""

from __future__ import annotations

import contextlib
import os
import signal
import threading
import time
from enum import IntEnum
from typing import Any

import numpy as np
from numba import njit, types

from exoleg.control.hierarchy import walk_control_step
from exoleg.device.sensors import FROZEN_S
from exoleg.layout import float_columns
from exoleg.runtime.clock import lateness_stats
from exoleg.runtime.link import BEAT_CHECK_TICKS
from exoleg.runtime.loop import (
    ENDS,
    LINK_LOST,
    OVERRUN_S,
    STOP_GRACE_S,
    SessionResult,
    late_run_text,
    late_run_ticks,
    not_stood_text,
    overrun_text,
    stood_text,
    stop_on_signals,
)
from exoleg.runtime.realtime import LOOP_PRIORITY, realtime_settings, saved_scheduling
from exoleg.runtime.sim_backend import RECORD
from exoleg.runtime.watch import JUMP_RAD, frozen_text, jump_text
from exoleg.tick import OUTPUT, SENSORS, Command, Mode
from exoleg.world.device import device_actuate, device_sense

#: clock_gettime and clock_nanosleep by name (resolved in the process, cacheable); the
#: timespec pointer passed as an address
_gettime = types.ExternalFunction("clock_gettime", types.int32(types.int32, types.intp))
_nanosleep = types.ExternalFunction(
    "clock_nanosleep", types.int32(types.int32, types.int32, types.intp, types.intp))
CLOCK_REALTIME, CLOCK_MONOTONIC, TIMER_ABSTIME = 0, 1, 1

#: ticks the ring holds: 4 s at 1 kHz, the outside's drain may fall that far behind
RING_TICKS = 4096
#: ticks of sensor noise per chunk (the simulated device's, drawn by the outside ahead)
NOISE_CHUNK = 4096
#: the last part of a period spent on the clock instead of asleep, s (a sleep to the
#: deadline wakes 60-110 us late on this VM, measured)
SPIN_S = 150e-6

#: commands the queue holds
QUEUE = 64
#: What the loop and the outside say to each other (one record; each field written by
#: one side): the ticks in the ring (the loop's), the ticks drained, a stop asked (its
#: code) and an end asked (:data:`~exoleg.runtime.loop.ENDS`), the commands queued and
#: taken, the E-stops sent and seen, the gain changes staged and swapped in, the chunk of
#: noise in each slot, and the queue of commands.
IO = np.dtype([("head", np.int64), ("drained", np.int64), ("stop", np.int64),
               ("end", np.int64), ("queued", np.int64), ("taken", np.int64),
               ("estops", np.int64), ("estops_seen", np.int64), ("gains", np.int64),
               ("gains_seen", np.int64), ("noise", np.int64, 2),
               ("queue", np.int64, QUEUE)])
#: what the ring keeps of each tick besides its records: its time and lateness (s), the
#: wall time its drives' command was written (s, for the link's applied commands) and
#: the operator's command it took
TICK = np.dtype([("t", np.float64), ("late", np.float64), ("wall", np.float64),
                 ("command", np.int64)])


class Stop(IntEnum):
    """How :func:`run_ticks` ended (its first return value)."""

    DURATION = 0  #: the duration ran out (standing or not walking)
    ASKED = 1  #: the outside asked (a signal, its own failure): torque off at once
    ENDED = 2  #: an end the outside asked came to a controlled stop
    FROZEN = 3  #: the foot board's readings froze
    JUMP = 4  #: an implausible joint reading
    NOT_FINITE = 5  #: the controller's command was not finite
    OVERRUN = 6  #: a tick later than the overrun limit: torque off
    LATE_RUN = 7  #: a run of late ticks came to a controlled stop
    NOT_STOOD = 8  #: a controlled stop did not stand within its grace
    RING_FULL = 9  #: the outside fell behind draining the ring
    NOISE_BEHIND = 10  #: the outside fell behind drawing the noise


#: the ends of a session besides the outside's (:data:`~exoleg.runtime.loop.ENDS`,
#: negative): the duration's and a run of late ticks
END_DURATION, END_LATE = 1, 2


@njit(cache=True, nogil=True)
def now(ts, clock):  # type: ignore[no-untyped-def]
    """The time on ``clock`` (s), through the scratch timespec ``ts`` (int64 (2,))."""
    _gettime(clock, ts.ctypes.data)
    return ts[0] + ts[1] * 1e-9


@njit(cache=True, nogil=True)
def _until(ts, deadline, spin):  # type: ignore[no-untyped-def]
    """Sleep to ``spin`` s before the monotonic ``deadline``, then spin to it; returns the
    time reached."""
    wake = deadline - spin
    t = now(ts, CLOCK_MONOTONIC)
    if wake > t:
        s = int(wake)
        ts[0] = s
        ts[1] = int((wake - s) * 1e9)
        _nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, ts.ctypes.data, 0)
    t = now(ts, CLOCK_MONOTONIC)
    while t < deadline:
        t = now(ts, CLOCK_MONOTONIC)
    return t


@njit(cache=True, nogil=True)
def _device_row(sk, D, tau, row):  # type: ignore[no-untyped-def]
    """What the log keeps of the simulated device this tick into ``row`` (one
    :data:`~exoleg.runtime.sim_backend.RECORD`), by name."""
    r = sk[0]
    for i in range(3):
        row.q_meas[i] = r.q[i]
        row.dq_meas[i] = r.dq[i]
        row.q[i] = D.x[1 + i]
        row.tau[i] = tau[i]
        row.interaction[i] = r.interaction[i]
        row.child[i] = D.child[i]
    for i in range(4):
        row.fsr[i] = r.fsr[i]
        row.fsr_other[i] = r.fsr_other[i]
    for i in range(2):
        row.acc[i] = r.accel[i]
    row.gyro = r.gyro
    row.pelvis = D.x[0]


@njit(cache=True, nogil=True, error_model="numpy")
def run_ticks(world, ctl, S, K, noise, ring, io, plan):  # type: ignore[no-untyped-def]
    """The session's ticks on the simulated device until it ends; returns (:class:`Stop`,
    the ticks run, two integers and a number saying more: the frozen ticks; the joint
    and its jump; the late tick and its lateness; the end (the outside's
    :data:`~exoleg.runtime.loop.ENDS` code, :data:`END_DURATION` or :data:`END_LATE`),
    the mode a controlled stop stood in (-1: none was needed) and its seconds).

    ``world``: (the plant's parameters, its world record, the actuators' records, the
    foot board's record, the IMU's x and y on the foot, the tick s, the plant's substeps,
    the child on a step (the scenery stays), the expected stride s, the other leg's
    support table, its standing height); ``ctl``: the walking controller's records
    (:meth:`~exoleg.control.hierarchy.WalkController.compiled`); ``S``: the device's
    state; ``K``: the child's records; ``noise``: (FSR unit normals (2 chunks, 4), IMU
    noise (2 chunks, 3), the IMU's bias (3,)), each chunk's number in the
    :data:`IO` record's ``noise``; ``ring``: (:data:`TICK` (n,), the device's
    :data:`~exoleg.runtime.sim_backend.RECORD` (n,), SENSORS (n,), OUTPUT (n,));
    ``io``: one :data:`IO`; ``plan``: (the ticks of
    the duration, the ticks of a controlled stop's grace, the scheduled commands' ticks
    and codes, the overrun limit s, the late ticks in a row that are a controlled stop,
    the frozen-board limit in ticks, the staged controller parameters and transparent
    law's (the operator's changes: a pair of records), the drives'
    command, envelope and delivered torque (3,) each, the true forces under the sensors
    (4,), a timespec (2,) and the start's monotonic time (0: now))."""
    p, w, A, sens, imu_x, imu_y, h, sub, step, stride, support, stand = world
    fsr_noise, imu_noise, bias = noise
    times, rows, SENS, OUT = ring
    n, grace, when, what, overrun, late_runs, frozen, staged, u, env, tau, fn, ts, t0 = plan
    D = S[0]
    x = io[0]  # what the outside and the loop say to each other
    cp, tp = ctl[0], ctl[10]  # (the parameters and the transparent law's: tunable)
    N = times.shape[0]
    nchunk = fsr_noise.shape[0] // 2
    limit = n
    k = 0
    late = 0.0
    next_t = t0 if t0 > 0.0 else now(ts, CLOCK_MONOTONIC)
    plan_i = 0
    stand_next = False  # a controlled stop's stand, before anything else but an E-stop
    deferred = 0  # a scheduled command put off by a tick
    ending = 0  # the end under way (a controlled stop), and when it began
    k_ending = 0
    late_run = 0
    same = 0
    walking = False
    while k < limit:
        if x.stop != 0:
            u[:] = 0.0
            return Stop.ASKED, k, x.stop, 0, 0.0
        if k - x.drained >= N:
            u[:] = 0.0
            return Stop.RING_FULL, k, N, 0, 0.0
        c = k // nchunk
        if x.noise[c % 2] != c:
            u[:] = 0.0
            return Stop.NOISE_BEHIND, k, c, 0, 0.0
        t = k * h
        slot = k % N
        sk = SENS[slot:slot + 1]
        ok_ = OUT[slot:slot + 1]
        # 1. the drives' last command acted over the tick that ended; the device now
        if k > 0:
            device_actuate((p, w, A), K, S, (h, sub), u, fn,
                           (walking and not step, (k - 1) * h, stride, support, stand),
                           (env, tau))
        i = (c % 2) * nchunk + k - c * nchunk
        device_sense((p, w, A), (sens, imu_x, imu_y), S, h, k == 0,
                     (fsr_noise[i], imu_noise[i], bias), sk, fn)
        r = sk[0]
        # 2. the watch on what the safety layer cannot see in the values
        if k > 0:
            prev = SENS[(k - 1) % N]
            alike = r.gyro == prev.gyro
            for j in range(4):
                alike = alike and r.fsr[j] == prev.fsr[j]
            same = same + 1 if alike else 0
            if same >= frozen:
                u[:] = 0.0
                return Stop.FROZEN, k + 1, same, 0, 0.0
            big = 0
            for j in range(3):
                if abs(r.q[j] - prev.q[j]) > abs(r.q[big] - prev.q[big]):
                    big = j
            if abs(r.q[big] - prev.q[big]) > JUMP_RAD:
                u[:] = 0.0
                return Stop.JUMP, k + 1, big, 0, abs(r.q[big] - prev.q[big])
        # 3. a gain change between ticks, whole; the operator's command: an E-stop
        # first, a controlled stop's stand, what was scheduled, then the queue
        if x.gains != x.gains_seen:
            cp[0] = staged[0][0]
            tp[0] = staged[1][0]
            x.gains_seen = x.gains
        command = 0
        if x.estops != x.estops_seen:
            x.estops_seen += 1
            command = Command.ESTOP
        elif stand_next:
            command, stand_next = Command.STAND, False
        elif deferred:
            command, deferred = deferred, 0
        while plan_i < when.shape[0] and when[plan_i] <= k:
            if command == 0:
                command = what[plan_i]
            else:
                deferred = what[plan_i]
            plan_i += 1
        if command == 0 and x.taken < x.queued:
            command = x.queue[x.taken % QUEUE]
            x.taken += 1
        r.command = command
        # 4. the controller's tick
        walk_control_step(ctl, sk, t, ok_)
        o = ok_[0]
        for j in range(3):
            if not np.isfinite(o.tau[j]):
                u[:] = 0.0
                return Stop.NOT_FINITE, k + 1, j, 0, o.tau[j]
        # 5. the record, the scenery and the drives
        tk = times[slot]
        tk.t = t
        tk.late = late
        tk.wall = now(ts, CLOCK_REALTIME)
        tk.command = command
        _device_row(sk, D, tau, rows[slot])
        walking = o.mode == Mode.WALKING or o.mode == Mode.STOPPING
        armed = walking or o.mode == Mode.STANDING
        for j in range(3):
            u[j] = o.tau[j] if armed else 0.0
        x.head = k + 1
        # 6. the session's end: a controlled stop while walking, else at once
        end = END_DURATION if k == n - 1 else 0
        if late_run >= late_runs:
            end = END_LATE
        if x.end != 0:
            end = x.end
        if end != 0 and not ending and walking:
            ending, k_ending = end, k
            stand_next = True
            limit = k + 1 + grace
        elif ending and not walking:
            u[:] = 0.0
            return Stop.ENDED, k + 1, ending, o.mode, (k - k_ending) * h
        elif end != 0 and not ending and end != END_DURATION:
            u[:] = 0.0
            return Stop.ENDED, k + 1, end, -1, 0.0
        # 7. the next deadline
        next_t += h
        reached = _until(ts, next_t, SPIN_S)
        late = reached - next_t
        if late > h:  # missed: resynchronised rather than run to catch up
            next_t = reached
            late_run += 1
        else:
            late_run = 0
        if late > overrun:
            u[:] = 0.0
            return Stop.OVERRUN, k + 1, k + 1, 0, late
        k += 1
    u[:] = 0.0
    if ending:  # the stop did not stand in time
        return Stop.NOT_STOOD, k, ending, 0, 0.0
    return Stop.DURATION, k, 0, 0, 0.0


def stopped_by(how: tuple[int, int, int, int, float], period: float, overrun: float,
               asked: list[str]) -> str:
    """How a compiled session ended (:func:`run_ticks`' answer) in the words the Python
    loop uses (:func:`~exoleg.runtime.loop.run_session`); ``asked``: why the outside
    asked it to stop."""
    stop, ticks, a, b, x = how
    ends = {END_DURATION: "duration", END_LATE: late_run_text(late_run_ticks(overrun)),
            **ENDS}
    if stop == Stop.DURATION:
        return "duration"
    if stop == Stop.ASKED:
        return f"{asked[0] if asked else 'asked to stop'}: torque off"
    if stop == Stop.ENDED:
        return (f"{ends[a]}: torque off" if b < 0
                else f"{stood_text(ends[a], b, x)}: torque off")
    if stop == Stop.NOT_STOOD:
        return not_stood_text(ends[a])
    if stop == Stop.FROZEN:
        return f"device fault: {frozen_text(a)}"
    if stop == Stop.JUMP:
        return f"device fault: {jump_text(a, x)}"
    if stop == Stop.NOT_FINITE:
        return f"controller error: the command to joint {a} was {x!r}"
    if stop == Stop.OVERRUN:
        return overrun_text(a, x, overrun)
    if stop == Stop.RING_FULL:
        return f"loop error: the log fell {a} ticks behind the loop: torque off"
    return (f"loop error: the simulated sensors' noise for ticks from {a * NOISE_CHUNK} was "
            "not drawn in time: torque off")


class _Outside:
    """What Python does beside the compiled loop: the ring drained into the log and the
    operator's link, the noise drawn ahead, the link's commands, gain changes and
    heartbeat handed to the loop through its shared array."""

    def __init__(self, backend: Any, controller: Any, n: int, grace: int, log: Any,
                 commands: dict[int, int], link: Any, tunable: bool, overrun: float
                 ) -> None:
        b = backend
        if b.k != 0:
            raise ValueError("the simulated device has already ticked")
        self.b, self.ctl, self.log, self.link, self.tunable = b, controller, log, link, tunable
        self.period = b.period
        N = RING_TICKS
        self.ring = (np.zeros(N, TICK), np.zeros(N, RECORD), np.zeros(N, SENSORS),
                     np.zeros(N, OUTPUT))
        self.io = np.zeros(1, IO)
        self.x = self.io[0]  # (a view: its fields write through)
        C = NOISE_CHUNK
        self.fsr, self.imu = np.zeros((2 * C, 8)), np.zeros((2 * C, 3))
        self.fsr[:C], self.imu[:C] = b.fsr_noise[:C], b.imu_noise[:C]
        self.chunk = 1
        self._draw()
        self.noise = (self.fsr, self.imu, b.bias)
        when = np.array(sorted(commands), dtype=np.int64)
        self.staged = (controller.cp.copy(), controller.tp.copy())
        self.change: dict[str, list[float]] = {}
        self.world = (b.p, b.w, b.dev.A, b.sens, b.dev.imu_x, -b.dev.depth, b.period,
                      b.substeps, bool(b.dev.step), b.dev.stride_time, b.dev.support,
                      b.dev.plant.support_height)
        self.plan = (n, grace, when, np.array([commands[k] for k in when], np.int64),
                     overrun, late_run_ticks(overrun),
                     max(1, int(round(FROZEN_S / b.period))), self.staged, b.u,
                     b.env, b.tau, b.fn, np.zeros(2, np.int64), 0.0)
        self.late = np.zeros(n + grace + 1)
        self.drained = 0
        self.latched = ""
        self.beat_at = 0.0

    def _draw(self) -> None:
        """The next chunk of the simulated sensors' noise, drawn as the device draws it,
        into the slot the loop has left."""
        C, c = NOISE_CHUNK, self.chunk
        slot = slice((c % 2) * C, (c % 2 + 1) * C)
        self.fsr[slot], self.imu[slot], _ = self.b._draw()
        self.x["noise"][c % 2] = c
        self.chunk += 1

    def args(self, ticks: int | None = None) -> tuple[Any, ...]:
        """:func:`run_ticks`' arguments (for ``ticks`` instead of the duration's)."""
        plan = self.plan if ticks is None else (ticks, *self.plan[1:])
        return (self.world, self.ctl.compiled(), self.b.S, self.b.K, self.noise, self.ring,
                self.io, plan)

    def arrays(self) -> list[np.ndarray]:
        """What the loop writes, to be in memory before it starts."""
        return [*self.ring, self.io, self.fsr, self.imu, self.late]

    def drain(self) -> None:
        """The ticks the loop has written since the last call into the log and the link."""
        from exoleg.control.safety import fault_event

        head = int(self.x["head"])
        if head <= self.drained:
            return
        times, rows, SENS, OUT = self.ring
        idx = np.arange(self.drained, head) % RING_TICKS
        ticks = times[idx]
        block = np.hstack([np.column_stack((ticks["t"], ticks["late"])),
                           float_columns(rows[idx]), float_columns(OUT[idx])])
        for row in block:
            self.log.append(row)
        self.late[self.drained:head] = ticks["late"]
        if not self.latched:
            hit = np.flatnonzero(OUT["fault"][idx])
            if hit.size:
                o = OUT[idx[hit[0]]]
                self.latched = (f"after {fault_event(o['fault'], o['fault_joint'])} at "
                                f"{times['t'][idx[hit[0]]]:.3f} s")
        if self.link is not None:
            for k, i in zip(range(self.drained, head), idx, strict=True):
                tk = times[i]
                self.link.loop_tick(k, tk["t"], OUT[i], SENS[i], tk["late"], self.period,
                                    publish=k % 10 == 0, wall=tk["wall"])
        self.drained = head
        self.x["drained"] = head

    def feed(self) -> None:
        """The noise drawn ahead; the link's commands, gains and heartbeat to the loop."""
        if int(self.x["head"]) > (self.chunk - 1) * NOISE_CHUNK:
            self._draw()
        link = self.link
        if link is None:
            return
        now = time.monotonic()
        if now - self.beat_at >= BEAT_CHECK_TICKS * self.period:
            self.beat_at = now
            if link.link_lost():
                self.x["end"] = LINK_LOST
        change = link.loop_receive()
        if change is not None and self.tunable:
            self.change.update(change)
        x = self.x
        if self.change and x["gains"] == x["gains_seen"]:  # the last change is in force
            cp, tp = self.ctl.gains_record(self.change, self.staged)
            self.staged[0][:], self.staged[1][:] = cp, tp
            self.change = {}
            x["gains"] += 1
            link.loop_gains(self.ctl.gains_now(self.staged))
        for code in link.loop_take():
            if code == Command.ESTOP:
                x["estops"] += 1
            elif code in ENDS:
                x["end"] = code
            elif x["queued"] - x["taken"] < QUEUE:
                x["queue"][x["queued"] % QUEUE] = code
                x["queued"] += 1

    def wait(self, seconds: float) -> None:
        """Until the link has something for the loop, or ``seconds``."""
        if self.link is not None:
            self.link.receiver.poll(seconds)
        else:
            time.sleep(seconds)


#: how often the outside drains the ring and feeds the loop, s
OUTSIDE_S = 2e-3


def lock_memory(arrays: list[np.ndarray]) -> bool:
    """Touch every page of ``arrays`` and lock them in memory where the OS permits
    (``mlock``: no page fault of 100 us+ in the loop); whether they were locked."""
    import ctypes

    libc = ctypes.CDLL(None, use_errno=True)
    locked = True
    for a in arrays:
        a.view(np.uint8)[...] = a.view(np.uint8)  # written: mapped now, not at the tick
        if libc.mlock(ctypes.c_void_p(a.ctypes.data), ctypes.c_size_t(a.nbytes)) != 0:
            locked = False
    return locked


def run_compiled(backend: Any, controller: Any, duration: float, log: Any,
                 commands: dict[int, int] | None = None, realtime: bool = True,
                 link: Any = None, tunable: bool = True, overrun: float = OVERRUN_S
                 ) -> SessionResult:
    """:func:`~exoleg.runtime.loop.run_session` of the simulated device
    (:class:`~exoleg.runtime.sim_backend.SimBackend`) under the walking controller, its
    ticks in :func:`run_ticks` on a thread of their own (at SCHED_FIFO with ``realtime``,
    above this thread, which drains and feeds it); the same log, link and ends."""
    import gc

    period = backend.period
    n = int(round(duration / period))
    outside = _Outside(backend, controller, n, int(round(STOP_GRACE_S / period)), log,
                       dict(commands or {}), link, tunable, overrun)
    # compiled (or loaded from the cache) on these very arrays, no tick run: the device's
    # and the controller's own warm-ups compile their Python path, not this one
    run_ticks(*outside.args(0))
    asked: list[str] = []
    old = stop_on_signals(asked)
    restore = saved_scheduling()
    rt: list[str] = []
    if realtime:
        rt.append("memory locked" if lock_memory(outside.arrays())
                  else "memory not locked (not permitted)")
        with contextlib.suppress(AttributeError, OSError):  # below the loop's thread
            os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(LOOP_PRIORITY - 1))
            rt.append(f"the log and link's thread SCHED_FIFO priority {LOOP_PRIORITY - 1}")
    else:
        lock_memory(outside.arrays())  # touched, at least
    answer: list[Any] = []

    def ticks() -> None:
        try:
            if realtime:
                rt.extend(realtime_settings((), period))
            rt.append("the tick compiled, off the interpreter lock")
            answer.append(run_ticks(*outside.args()))
        except BaseException as e:  # (numba raises nothing in the loop; a bug would)
            answer.append(e)

    thread = threading.Thread(target=ticks, name="exoleg-tick", daemon=True)
    failure = ""
    gc.collect()
    gc.freeze()
    try:
        thread.start()
        while thread.is_alive():
            outside.drain()
            outside.feed()
            if asked and not outside.x["stop"]:
                outside.x["stop"] = 1
            outside.wait(OUTSIDE_S)
    except BaseException as e:  # the log (disk full), the link...: the torque off first
        outside.x["stop"] = 1
        thread.join()
        if not isinstance(e, Exception):
            raise
        failure = f"loop error: {type(e).__name__}: {e}: torque off"
    finally:
        outside.x["stop"] = 1
        thread.join()
        gc.unfreeze()
        for s, h in old.items():
            signal.signal(s, h)
        restore()
    try:
        outside.drain()
    finally:
        log.close()
    how = answer[0] if answer else RuntimeError("the tick's thread gave no answer")
    if isinstance(how, BaseException):
        raise how
    reason = failure or stopped_by(tuple(how), period, overrun, asked)
    if outside.latched:
        reason = f"{reason} ({outside.latched})"
    ticks_run = int(how[1])
    late = outside.late[1:ticks_run]
    if how[0] == Stop.OVERRUN:
        late = np.append(late, how[4])
    return SessionResult(ticks=ticks_run, stopped_by=reason,
                         timing=lateness_stats(late, period), realtime=rt)
