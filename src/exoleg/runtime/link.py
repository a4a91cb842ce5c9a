"""The link between the 1 kHz loop and the operator's side, across processes.

The loop and the web server never share a process: a web server in the loop's process
would hold the GIL for milliseconds at a time (JSON, WebSocket frames, page requests) and
the loop would wait for it. The link is two OS objects the loop can use without ever
blocking:

* a **shared-memory block** the loop writes (a seqlock: an odd sequence number while it
  writes) -- the latest tick at 100 Hz, the gains in force, and a ring of the commands
  the controller has applied with the wall time it applied them; the web side copies it
  when it likes and retries a torn copy;
* a **pipe** from the web side to the loop, which the loop polls once a tick without
  waiting: commands, gain changes, and the request to end the session. An E-stop found
  in the pipe goes before anything queued with it;
* a **heartbeat** the web side's event loop beats every few milliseconds
  (:meth:`LoopLink.web_beat`, the system's monotonic clock, shared by every process):
  a heartbeat older than :data:`LINK_TIMEOUT_S` -- the server's process dead or hung,
  under ``exoleg hmi`` and under ``exoleg run --hmi`` alike -- is a lost link
  (:data:`~exoleg.runtime.loop.LINK_LOST`): nobody could stop the device from a page, so
  the session comes to a controlled stop and the torque goes off. So is a link the web
  side has not beaten within :data:`LINK_TIMEOUT_S` of the loop's first look at it (a
  server that hung before its first beat).

:class:`LoopLink` is picklable (its parts are ``multiprocessing`` objects): made in one
process, passed to the other as a ``Process`` argument.
"""

from __future__ import annotations

import math
import multiprocessing as mp
import time
from collections import deque
from typing import Any

import numpy as np

from exoleg.control.gait_phase import Event
from exoleg.control.gears import LAW_TUNABLE
from exoleg.control.transparency import TRANSPARENCY
from exoleg.control.walk_gains import PARAMS, TUNABLE
from exoleg.runtime.loop import END_SESSION, LINK_LOST
from exoleg.tick import OUTPUT, SENSORS, Command

#: gains the operator may change, in the order they sit in the shared block
GAIN_NAMES = TUNABLE
RING = 32
#: A heartbeat of the web side older than this is a lost link, s. The server's event
#: loop beats every 5 ms; its longest stall measured here under the browser tests was
#: well under 0.1 s (the web side never runs a fit or a plot on its event loop).
LINK_TIMEOUT_S = 1.0
#: how often the loop looks at the heartbeat, ticks
BEAT_CHECK_TICKS = 100


def _names(record: Any) -> Any:
    """The field names of a record (np.void) or the keys of a mapping."""
    return record.dtype.names if isinstance(record, np.void) else record


def _shape(dtype: np.dtype, name: str) -> tuple[int, ...]:
    return tuple(dtype[name].shape)


def _gain_shape(name: str) -> tuple[int, ...]:
    """A tunable's shape: in the walking controller's parameters, or the transparent
    law's (:data:`~exoleg.control.gears.LAW_TUNABLE`)."""
    return _shape(TRANSPARENCY if name in LAW_TUNABLE else PARAMS, name)


#: the shared block, every field a float64 (one seqlock over the whole): the sequence
#: number, the tick's time, the controller's output (:data:`OUTPUT`) and the device's
#: joint and foot readings (:data:`SENSORS`), the loop's timing, whether it runs, the
#: gains in force (:data:`GAIN_NAMES`, as :data:`~exoleg.control.hierarchy.PARAMS` and
#: :data:`~exoleg.control.transparency.TRANSPARENCY` hold them) and the bounds the
#: session sets on the transparent law's (per joint: lower, upper), the ring of applied
#: commands (command, request id, tick, wall time, refused by the supervisor (1) or not
#: (0), the mode then), the steps (initial contacts) so far and the ring of every tick's
#: gait events (time, event bits)
PUBLISHED = ("mode", "phase", "gait_source", "gait_fraction", "events", "safety_status",
             "q_ref", "tau", "fault", "fault_joint", "fault_value", "fault_limit", "refused",
             "winding_temp", "gear_torque", "support_mode", "support_level", "cuff")
READINGS = ("q", "dq", "fsr", "interaction")
BLOCK = np.dtype([("seq", "f8"), ("t", "f8")]
                 + [(n, "f8", _shape(OUTPUT, n)) for n in PUBLISHED]
                 + [(n, "f8", _shape(SENSORS, n)) for n in READINGS]
                 + [("late_us", "f8"), ("late_max_us", "f8"), ("missed", "f8"),
                    ("tick", "f8"), ("running", "f8"), ("gains_set", "f8")]
                 + [("gain_" + n, "f8", _gain_shape(n)) for n in GAIN_NAMES]
                 + [("bound_" + n, "f8", (3, 2)) for n in LAW_TUNABLE]
                 + [("applied", "f8"), ("ring", "f8", (RING, 6)),
                    ("steps", "f8"), ("n_events", "f8"), ("event_ring", "f8", (RING, 2))])
SIZE = BLOCK.itemsize // 8
#: the snapshot's fields, in the block's order
_SNAPSHOT = ("t", *PUBLISHED, *READINGS, "late_us", "late_max_us", "missed", "tick",
             "running")
_INTS = {"mode", "phase", "gait_source", "events", "safety_status", "fault", "fault_joint",
         "refused", "missed", "tick", "support_mode"}
_RUNNING = ("starting", "running", "ended")
_TICKING, _ENDED = float(_RUNNING.index("running")), float(_RUNNING.index("ended"))


class LoopLink:
    """Shared block + command pipe between the loop (``loop_*`` methods) and the web
    side (``web_*`` methods). Make it with :meth:`new` before starting the other
    process."""

    def __init__(self, block: Any, receiver: Any, sender: Any, beat: Any) -> None:
        self.block = block
        self.receiver = receiver
        self.sender = sender
        self.beat = beat  # the web side's last heartbeat, time.monotonic() (0: none yet)
        self._view: np.void | None = None
        self._queue: deque[tuple[int, int]] = deque()
        self._inflight: list[tuple[int, int]] = []
        self._events = 0
        self._status = 0
        self._late_max = 0.0
        self._missed = 0
        self._polls = 0
        self._first_look: float | None = None  # the loop's first look at the heartbeat

    @classmethod
    def new(cls) -> LoopLink:
        ctx = mp.get_context("spawn")
        receiver, sender = ctx.Pipe(duplex=False)
        return cls(ctx.RawArray("d", SIZE), receiver, sender, ctx.RawValue("d", 0.0))

    def __getstate__(self) -> dict[str, Any]:
        return {"block": self.block, "receiver": self.receiver, "sender": self.sender,
                "beat": self.beat}

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.__init__(state["block"], state["receiver"], state["sender"],  # type: ignore[misc]
                      state["beat"])

    @property
    def view(self) -> np.void:
        """The shared block as one :data:`BLOCK` record (fields by name)."""
        if self._view is None:
            self._view = np.frombuffer(self.block, dtype=BLOCK)[0]
        return self._view

    # ------------------------------------------------------------ the loop's side
    def _begin(self) -> np.void:
        v = self.view
        v["seq"] += 1.0  # odd: being written
        return v

    def loop_gains(self, gains: dict[str, list[float]],
                   bounds: dict[str, list[list[float]]] | None = None) -> None:
        """The gains in force (at the start and after every change) and, at the start,
        the bounds on the transparent law's (:func:`~exoleg.control.gears.law_bounds`;
        none given: each held where it is)."""
        v = self._begin()
        for k in GAIN_NAMES:
            v["gain_" + k] = gains[k] if _gain_shape(k) else gains[k][0]
        if not v["gains_set"]:
            for k in LAW_TUNABLE:
                v["bound_" + k] = (bounds[k] if bounds is not None else
                                   [[x, x] for x in gains[k]])
        v["gains_set"] = 1.0
        v["seq"] += 1.0

    def loop_ended(self) -> None:
        """The session is over (``running``: 0 before the first tick, 1 from it on)."""
        v = self._begin()
        v["running"] = _ENDED
        v["seq"] += 1.0

    def loop_poll(self) -> tuple[int, dict[str, list[float]] | None]:
        """What the web side sent: (command for the next tick or 0, a gain change or
        None). Never waits; an E-stop goes first. :data:`LINK_LOST` once the web side's
        heartbeat is older than :data:`LINK_TIMEOUT_S` (looked at every
        :data:`BEAT_CHECK_TICKS` calls)."""
        self._polls += 1
        if self._polls % BEAT_CHECK_TICKS == 0 and self.link_lost():
            return LINK_LOST, None
        change = self.loop_receive()
        if not self._queue:
            return 0, change
        code, rid = self._queue.popleft()
        self._inflight.append((code, rid))
        return code, change

    def loop_receive(self) -> dict[str, list[float]] | None:
        """Move what the web side sent into the loop's queue (an E-stop before anything
        queued); returns the gain change sent, merged, or None. Never waits."""
        change = None
        while self.receiver.poll():
            kind, value, rid = self.receiver.recv()
            if kind == "gains":
                change = {**(change or {}), **value}  # bounds checked on the web side
            elif value == Command.ESTOP:
                self._queue.appendleft((int(value), int(rid)))
            else:
                self._queue.append((int(value), int(rid)))
        return change

    def loop_take(self) -> list[int]:
        """Every command queued, in order, each noted as handed to the controller (for
        a loop that queues them itself: :mod:`exoleg.runtime.ticker`)."""
        codes = []
        while self._queue:
            code, rid = self._queue.popleft()
            self._inflight.append((code, rid))
            codes.append(code)
        return codes

    def loop_tick(self, k: int, t: float, out: Any, sensors: Any, late: float,
                  period: float, publish: bool, wall: float | None = None) -> None:
        """After tick ``k``: note a command the controller applied this tick (with the
        wall time, after the drives' command was written -- ``wall`` when the tick
        stamped it, else now) and, when ``publish``, the tick's state. ``out``, ``sensors``:
        the tick's :data:`OUTPUT` and :data:`SENSORS` fields by name."""
        events = int(out["events"])
        self._events |= events
        self._status |= int(out["safety_status"])
        self._late_max = max(self._late_max, late)
        if late > period:
            self._missed += 1
        applied = int(sensors["command"])
        hit = next((x for x in self._inflight if x[0] == applied), None) if applied else None
        if not publish and hit is None and not events:
            return
        v = self._begin()
        if events:  # every event, for the pages (the publication ORs them)
            n = int(v["n_events"])
            v["event_ring"][n % RING] = (t, events)
            v["n_events"] = n + 1
            if events & Event.IC:
                v["steps"] += 1
        if hit is not None:
            self._inflight.remove(hit)
            n = int(v["applied"])
            refused = float(int(out["refused"]) == hit[0])
            v["ring"][n % RING] = (hit[0], hit[1], k, time.time() if wall is None else wall,
                                   refused, int(out["mode"]))
            v["applied"] = n + 1
        if publish:
            v["t"] = t
            for name in PUBLISHED:
                v[name] = out[name]
            for name in READINGS:
                v[name] = sensors[name] if name in _names(sensors) else np.nan  # (no cuffs)
            v["events"] = self._events  # ORed since the last publication
            v["safety_status"] = self._status
            v["late_us"] = late * 1e6
            v["late_max_us"] = self._late_max * 1e6
            v["missed"] = self._missed
            v["tick"] = k
            v["running"] = _TICKING
            self._events = self._status = 0
            self._late_max = 0.0
        v["seq"] += 1.0

    def link_lost(self) -> bool:
        """Whether the web side has not beaten for :data:`LINK_TIMEOUT_S` -- or, never
        having beaten, within that of this side's first look (the loop's; a link made
        for a server that hung before it beat would otherwise never be lost)."""
        beat, now = float(self.beat.value), time.monotonic()
        if beat > 0.0:
            return now - beat > LINK_TIMEOUT_S
        if self._first_look is None:
            self._first_look = now
        return now - self._first_look > LINK_TIMEOUT_S

    # ------------------------------------------------------------ the web side
    def web_seal(self) -> bool:
        """After the loop's process has ended (and only then): a block it left mid-write
        -- killed while writing, an odd sequence -- can never be completed, and every copy
        of it would go on failing; sealed, marked ended with an even sequence, it reads
        again. Returns whether it was torn: its fields may then mix two writes, so nothing
        in it is taken as the session's own (the settings it ended with)."""
        v = self.view
        if float(v["seq"]) % 2 == 0:
            return False
        v["running"] = _ENDED
        v["seq"] += 1.0
        return True

    def web_beat(self) -> None:
        """The web side is alive (its event loop calls this every few ms)."""
        self.beat.value = time.monotonic()

    def web_send(self, command: int, request_id: int = 0) -> None:
        self.sender.send(("command", int(command), int(request_id)))

    def web_gains(self, change: dict[str, list[float]]) -> None:
        self.sender.send(("gains", change, 0))

    def web_end(self) -> None:
        self.sender.send(("command", END_SESSION, 0))

    def web_copy(self) -> np.void:
        """A consistent copy of the shared block (retries a copy torn by a write)."""
        v = self.view
        for _ in range(1000):
            s = float(v["seq"])
            c = v.copy()
            if s % 2 == 0 and v["seq"] == s:
                return c
            time.sleep(1e-5)  # (each at least the OS's wake-up: tens of us)
        # (the same words each time: the console's watch says a failure once until it
        # changes -- 1000 copies took 60-100 ms here)
        raise RuntimeError("the loop's shared block stayed mid-write over 1000 copies")

    @staticmethod
    def snapshot(c: np.void) -> dict[str, Any]:
        """The latest tick as JSON-ready values (angles rad, torques N m, FSR counts):
        the fields of :data:`BLOCK` the page shows, by name."""
        out: dict[str, Any] = {}
        for name in _SNAPSHOT:
            x = c[name]
            # NaN (a reading the device does not have) is null: JSON has no NaN
            out[name] = ([float(a) if math.isfinite(a) else None for a in x]
                         if BLOCK[name].shape else int(x) if name in _INTS else float(x))
        out["running"] = _RUNNING[int(out["running"])]
        out["steps"] = int(c["steps"])
        out["support"] = float(c["gain_support"]) if c["gains_set"] else None
        n = int(c["n_events"])
        out["event_log"] = [[i, float(c["event_ring"][i % RING][0]),
                             int(c["event_ring"][i % RING][1])]
                            for i in range(max(0, n - RING), n)]
        return out

    @staticmethod
    def running(c: np.void) -> str:
        """'starting' (before the first tick), 'running' or 'ended'."""
        return _RUNNING[int(c["running"])]

    @staticmethod
    def gains(c: np.void) -> dict[str, list[float]] | None:
        """The gains in force; None before the session has published them."""
        if not c["gains_set"]:
            return None
        return {n: [float(x) for x in np.atleast_1d(c["gain_" + n])] for n in GAIN_NAMES}

    @staticmethod
    def law_bounds(c: np.void) -> dict[str, list[list[float]]]:
        """The bounds the session set on the transparent law's tunables (per joint,
        [lower, upper]); empty before the session has published its gains."""
        if not c["gains_set"]:
            return {}
        return {n: c["bound_" + n].tolist() for n in LAW_TUNABLE}

    @staticmethod
    def applied(c: np.void, since: int
                ) -> tuple[int, list[tuple[int, int, int, float, bool, int]]]:
        """Commands the loop handed the controller after the first ``since``: (count now,
        [(command, request id, tick, wall time, refused by the supervisor, mode)])."""
        n = int(c["applied"])
        ring = c["ring"]
        first = max(since, n - RING)
        return n, [(int(r[0]), int(r[1]), int(r[2]), float(r[3]), bool(r[4]), int(r[5]))
                   for r in (ring[i % RING] for i in range(first, n))]
