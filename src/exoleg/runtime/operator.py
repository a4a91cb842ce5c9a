"""The operator rules of a session, apart from any transport: one operator holds control
at a time (a lease that lapses after :data:`LEASE_S` s of silence), every control action
needs the session's token and that operator (an E-stop needs neither), gain changes are
bounded (0 to twice their value at the start, the support level and the bounds on
assist-as-needed's support 0-1, the transparent law's inertia share and acceleration
estimate within the bounds the session sets from its gears' modes:
:func:`~exoleg.control.gears.law_bounds`), and every action,
accepted or refused, and the loop's application of each command go to ``control.log``
with their wall times and the operator's name. The device is never armed with nobody in
control: an operator's hold that is given up, or lapses, while the device is armed brings
it to a controlled stop (stand, while walking) and then disarms it, with an alarm in the
log and on every page (:meth:`OperatorRules.watch_once`).
:class:`~exoleg.runtime.control_api.ControlAPI` serves them over HTTP; a script or a test
may call them directly."""

from __future__ import annotations

import contextvars
import json
import math
import secrets
import threading
import time
from pathlib import Path
from typing import Any

from exoleg.control.gears import LAW_TUNABLE
from exoleg.control.hierarchy import BOUNDS
from exoleg.control.safety import fault_detail
from exoleg.control.supervisor import refusal
from exoleg.runtime.link import GAIN_NAMES, LoopLink
from exoleg.tick import ARMED_MODES, Command, Mode

#: the operator's commands by the names the API takes, from the enumeration
COMMANDS = {m.name.lower(): m for m in Command if m != Command.NONE}
NAMES = {int(v): k for k, v in COMMANDS.items()}
#: commands anyone may send (no token, no operator): stopping the device
UNGUARDED = {"estop"}
#: an operator's hold on control lapses after this long without a request from them, s
LEASE_S = 5.0
#: the tunables that are shares (0-1), not gains
SHARES = ("support", *BOUNDS)
#: the operator holding control who sent the request being handled (their name), for
#: the records of what it does (set by :meth:`OperatorRules.authorise`)
REQUEST_OPERATOR: contextvars.ContextVar[str | None] = contextvars.ContextVar(
    "exoleg_operator", default=None)
NO_TOKEN = ("no valid token: enter the token printed when exoleg started (Control page, "
            "Token; programs send Authorization: Bearer <token>)")


def _json_safe(v: Any) -> Any:
    """A value the control log and its JSON reader can hold: a non-finite float as its
    text (JSON has no Infinity or NaN)."""
    if isinstance(v, float) and not math.isfinite(v):
        return repr(v)
    return v


class OperatorRules:
    """The web side's state: the session attached, the operator holding control, the
    actions logged. Thread-safe (the server's event loop and the HMI's threads)."""

    def __init__(self, token: str | None = None, folder: str | Path = ".") -> None:
        self.token = token or secrets.token_urlsafe(16)
        self.lock = threading.RLock()
        self.link: LoopLink | None = None
        self.home = Path(folder)  # interface.log: what is done with no session running
        self.folder = self.home  # the session's, while one is attached
        self.bounds: dict[str, list[list[float]]] = {}
        self.actions: list[dict[str, Any]] = []
        self.operator: dict[str, Any] | None = None
        self.requests: dict[int, dict[str, Any]] = {}
        # applied E-stops whose page's click time is still being read: their record waits
        # for it (:meth:`clicked`)
        self.held: dict[int, tuple[tuple[Any, ...], dict[str, Any]]] = {}
        self.next_id = 1
        self.seen_applied = 0
        self.alarm: dict[str, Any] | None = None  # the latest alarm, on every page
        # nobody holds control while the device is armed: why, and the mode a command
        # was last sent for (a controlled stop, then disarm: :meth:`_settle_unattended`)
        self.unattended: str | None = None
        self._unattended_sent = -1
        self.duration: float | None = None  # the session's planned length, s
        self.body_mass: float | None = None  # the child's, kg (the cuffs' torque per kg)
        self.ended: dict[str, Any] | None = None  # how the last session ended
        self.outcomes: dict[int, tuple[bool, str]] = {}  # request id -> applied, why not
        self._seq, self._seq_seen = -1.0, time.monotonic()  # the loop's last publication

    def log_path(self, source: str) -> Path:
        """Where an action from ``source`` is logged: the session's ``control.log`` while
        it runs (the loop's applications and the session's end, sources ``loop`` and
        ``session``, always), else the interface's own
        ``interface.log`` -- never in a session that has ended."""
        with self.lock:
            link, folder = self.link, self.folder
        if link is not None and (source in ("loop", "session")
                                 or LoopLink.running(link.web_copy()) != "ended"):
            return folder / "control.log"
        return self.home / "interface.log"

    def attach(self, link: LoopLink, folder: str | Path, duration: float | None = None,
               body_mass: float | None = None) -> None:
        """A session starts: its link, its folder (control.log), its planned length (s)
        and the child's body mass (kg), each None when unknown."""
        with self.lock:
            self.link, self.folder = link, Path(folder)
            self.bounds, self.actions, self.requests, self.outcomes = {}, [], {}, {}
            self.held = {}
            self.seen_applied = 0
            self.alarm = None
            self.unattended = None
            self.duration, self.body_mass = duration, body_mass
            self._seq, self._seq_seen = -1.0, time.monotonic()

    def detach(self, ended: dict[str, Any] | None = None) -> None:
        """The session is over; ``ended``: how (``session``, ``stopped_by``, ``time``,
        ``fault_text``), kept for every page, each of which keeps showing it until its
        operator acknowledges it (a page's own record: a newer session does not hide it)."""
        with self.lock:
            self.link, self.folder = None, self.home
            self.unattended = None
            if ended is not None:
                self.ended = ended

    # ------------------------------------------------------------------ bookkeeping
    def record(self, source: str, command: str, accepted: bool, why: str = "",
               log: Path | None = None, **extra: Any) -> dict[str, Any]:
        """One action in the log (``log``, default :meth:`log_path`) with its time, source
        and the operator's name, and in :attr:`actions`."""
        operator = extra.pop("operator", None) or REQUEST_OPERATOR.get()
        entry = {"time": time.time(), "source": source,
                 **({"operator": operator} if operator else {}), "command": command,
                 "accepted": accepted, **({"why": why} if why else {}),
                 **{k: _json_safe(v) for k, v in extra.items()}}
        with self.lock:
            self.actions.append(entry)
            try:
                with (log or self.log_path(source)).open("a") as f:
                    f.write(json.dumps(entry) + "\n")
            except OSError as e:  # the action stands; the failure is said where it is seen
                entry["log_error"] = str(e)
        return entry

    def state(self) -> dict[str, Any]:
        """The latest tick (:meth:`LoopLink.snapshot`), how long ago the loop last
        published (``loop_age_s``), the operator holding control, the latest alarm, how
        the last session ended (``ended``), the session's planned length (``duration_s``)
        and the child's body mass (``body_mass``)."""
        with self.lock:
            link, alarm, ended = self.link, self.alarm, self.ended
            duration, mass = self.duration, self.body_mass
            age = time.monotonic() - self._seq_seen
        holder = self.public(self.holder())
        if link is None:
            return {"running": "none", "alarm": alarm, "holder": holder, "ended": ended}
        out = LoopLink.snapshot(link.web_copy())
        out.update(loop_age_s=round(age, 3), alarm=alarm, holder=holder, ended=ended,
                   duration_s=duration, body_mass=mass,
                   fault_text=fault_detail(out["fault"], out["fault_joint"],
                                           out["fault_value"], out["fault_limit"]))
        return out

    def gains(self) -> tuple[dict[str, list[float]], dict[str, list[list[float]]]]:
        """The gains in force and their bounds (set from the first gains the session
        published); empty before the session has started."""
        with self.lock:
            link = self.link
        if link is None:
            return {}, {}
        c = link.web_copy()
        g = LoopLink.gains(c)
        if g is None:  # not yet published by the session
            return {}, {}
        with self.lock:
            if not self.bounds:  # the transparent law's: the session's own
                self.bounds = {**{k: [[0.0, 1.0]] * len(v) if k in SHARES else
                                  [[0.0, 2.0 * x] for x in v]
                                  for k, v in g.items() if k not in LAW_TUNABLE},
                               **LoopLink.law_bounds(c)}
            return g, dict(self.bounds)

    def check_gains(self, change: dict[str, list[float]]) -> str:
        """Why ``change`` is refused ('' when it is within bounds)."""
        now, bounds = self.gains()
        if not bounds:
            return ("no session is running" if self.link is None else
                    "this session has no gains to change (identification's plan)")
        for k, v in change.items():
            if k not in bounds:
                return f"unknown gain {k!r} (allowed: {', '.join(GAIN_NAMES)})"
            if len(v) != len(bounds[k]):
                return f"{k}: expected {len(bounds[k])} values, got {len(v)}"
            for i, (x, (lo, hi)) in enumerate(zip(v, bounds[k], strict=True)):
                if not lo <= x <= hi:
                    return (f"{k}[{i}] = {x:g} is outside {lo:g}-{hi:g}"
                            + (" (the law's gear modes, the device's own setting: "
                               "exoleg validate --transparency)" if k in LAW_TUNABLE else ""))
        low, high = (change.get(k, now[k]) for k in BOUNDS)
        for i, (a, b) in enumerate(zip(low, high, strict=True)):
            if a > b:
                return f"{BOUNDS[0]}[{i}] = {a:g} is above {BOUNDS[1]}[{i}] = {b:g}"
        return ""

    def poll_applied(self) -> None:
        """Log the commands the loop has applied since the last call, with the time from
        the request (and from the click) to the tick that wrote the drives' command."""
        with self.lock:  # the server's task and the HMI's session watcher both call it
            link = self.link
            if link is None:
                return
            n, done = LoopLink.applied(link.web_copy(), self.seen_applied)
            self.seen_applied = n
            for code, rid, tick, wall, refused, mode in done:
                req = self.requests.pop(rid, {})
                extra: dict[str, Any] = {"tick": tick, "request": rid}
                if "received" in req:
                    extra["after_request_ms"] = round((wall - req["received"]) * 1e3, 3)
                if "clicked_at" in req:
                    extra["after_click_ms"] = round((wall - req["clicked_at"]) * 1e3, 3)
                why = refusal(code, mode) if refused else ""
                self.outcomes[rid] = (not refused, why)
                args = ("loop", NAMES.get(code, str(code)), not refused)
                kwargs = {"why": why, "applied": wall, **extra}
                if req.get("click_to_come"):  # logged once the page's click time is read
                    self.held[rid] = (args, kwargs)
                else:
                    self.record(*args, **kwargs)
            while len(self.outcomes) > 256:  # the pages read theirs within a second
                self.outcomes.pop(next(iter(self.outcomes)))

    def watch_once(self, beat: bool = True) -> None:
        """The web side's watch, every few ms: the heartbeat the loop checks (when
        ``beat``), the commands applied, the loop's last publication, a lapsed hold, and
        an armed device nobody controls brought to rest (:meth:`_settle_unattended`)."""
        with self.lock:
            link = self.link
        if link is not None:
            if beat:
                link.web_beat()
            self.poll_applied()
            seq = float(link.view["seq"])
            with self.lock:
                if seq != self._seq:
                    self._seq, self._seq_seen = seq, time.monotonic()
        self.holder()
        self._settle_unattended()

    def _mode_now(self) -> int | None:
        """The supervisor's mode while the session's loop runs (None otherwise)."""
        with self.lock:
            link = self.link
        if link is None:
            return None
        c = link.web_copy()
        return int(c["mode"]) if LoopLink.running(c) == "running" else None

    def _unattended_now(self, op: dict[str, Any], what: str) -> None:
        """Nobody holds control any more (``op``'s hold ended: ``what``). While the
        device is armed that may not stay so: a controlled stop (while walking), then
        disarm, with an alarm on every page and in the log; else a note in the log."""
        mode = self._mode_now()
        if mode is None or mode not in ARMED_MODES:
            self.record("hmi", "control ended", True, why=what, operator=op["name"])
            return
        steps = ("controlled stop to standing, then disarm" if mode != Mode.STANDING
                 else "disarm")
        text = (f"nobody in control: {what} while {Mode(mode).name}: {steps}; take "
                "control to go on")
        with self.lock:
            self.unattended, self._unattended_sent = text, -1
            self.alarm = {"time": time.time(), "text": text}
        self.record("hmi", "alarm", True, why=text, operator=op["name"])
        self._settle_unattended()

    def _settle_unattended(self) -> None:
        """While nobody holds control of an armed device: stand it (walking), then
        disarm it (standing); done once it is disarmed, faulted, ended, or someone takes
        control. One command for each mode met (the loop publishes at 100 Hz)."""
        with self.lock:
            if self.unattended is None:
                return
            if self.operator is not None:
                self.unattended = None
                return
        mode = self._mode_now()
        if mode is None or mode not in ARMED_MODES:
            with self.lock:
                why, self.unattended = self.unattended, None
            self.record("hmi", "nobody in control: at rest", True,
                        why=f"{'session ended' if mode is None else Mode(mode).name}; "
                            f"after: {why}")
            return
        with self.lock:
            if self._unattended_sent == mode:
                return
            self._unattended_sent = mode
        if mode == Mode.WALKING:
            self.send("stand")
        elif mode == Mode.STANDING:
            self.send("disarm")

    def release(self, source: str) -> None:
        """The operator holding control gives it up (:meth:`authorise` first)."""
        with self.lock:
            op, self.operator = self.operator, None
        self.record(source, "give up control", True)
        if op is not None:
            self._unattended_now(op, f"{op['name']} gave up control")

    # ------------------------------------------------------------------ control
    def holder(self) -> dict[str, Any] | None:
        """The operator holding control (None when nobody does; a hold that lapsed
        goes: no word from their page for :data:`LEASE_S` s, :meth:`_unattended_now`)."""
        with self.lock:
            op = self.operator
            if op is None or time.time() - op["seen"] <= LEASE_S:
                return op
            self.operator = None
        self._unattended_now(op, f"link lost: {op['name']}'s hold on control lapsed (no "
                                 f"word from their page for {LEASE_S:g} s)")
        return None

    def who(self, headers: Any) -> str | None:
        """The name of the operator holding control when ``headers`` are theirs (the
        token and their id), for the records of what the request does; else None."""
        with self.lock:
            op = self.operator
        if (op is None or not self.has_token(headers)
                or not secrets.compare_digest(headers.get("x-operator", ""), op["id"])):
            return None
        REQUEST_OPERATOR.set(op["name"])
        return str(op["name"])

    def has_token(self, headers: Any) -> bool:
        return secrets.compare_digest(headers.get("authorization", ""), f"Bearer {self.token}")

    def authorise(self, headers: Any, source: str, what: str) -> str:
        """'' when the request carries the token and the operator holding control; else
        why not (and the refusal is logged)."""
        why = ""
        if not self.has_token(headers):
            why = NO_TOKEN
        else:
            op = self.holder()
            oid = headers.get("x-operator", "")
            if op is None:
                why = ("take control first (Control page, Take control): nobody holds "
                       "it")
            elif not secrets.compare_digest(oid, op["id"]):
                why = (f"control is held by {op['name']} ({op['source']}); you can view "
                       "only")
            else:
                with self.lock:
                    op["seen"] = time.time()
                REQUEST_OPERATOR.set(op["name"])
        if why:
            self.record(source, what, False, why)
        return why

    def take(self, headers: Any, source: str, name: str) -> tuple[int, dict[str, Any]]:
        if not self.has_token(headers):
            self.record(source, f"take control ({name})", False, NO_TOKEN)
            return 401, {"error": NO_TOKEN}
        with self.lock:
            op = self.holder()
            if op is not None and not secrets.compare_digest(
                    op["id"], headers.get("x-operator", "")):
                why = (f"control is held by {op['name']} ({op['source']}) since "
                       f"{time.strftime('%H:%M:%S', time.localtime(op['since']))}; you can "
                       "view only")
                self.record(source, f"take control ({name})", False, why)
                return 409, {"error": why, "holder": self.public(op)}
            now = time.time()
            self.operator = op = {"id": secrets.token_urlsafe(12), "name": name,
                                  "source": source, "since": now, "seen": now}
            alarm, self.alarm = self.alarm, None  # taking control again acknowledges it
        REQUEST_OPERATOR.set(name)
        self.record(source, f"take control ({name})", True,
                    why=f"acknowledges the alarm: {alarm['text']}" if alarm else "")
        return 200, {"operator": op["id"], "holder": self.public(op)}

    @staticmethod
    def public(op: dict[str, Any] | None) -> dict[str, Any] | None:
        return None if op is None else {k: op[k] for k in ("name", "source", "since")}

    def outcome(self, rid: int) -> tuple[bool, str] | None:
        """Whether the supervisor applied request ``rid`` and why not (None: not yet)."""
        with self.lock:
            return self.outcomes.get(rid)

    def send(self, name: str, clicked_at: float | None = None, click_to_come: bool = False
             ) -> tuple[str, int]:
        """Queue ``name`` for the loop: ('' or why it cannot go, its request id, whose
        outcome :meth:`outcome` gives once the loop has applied it), with the page's click
        time (s, wall clock) when known, or to come (:meth:`clicked`)."""
        with self.lock:
            link = self.link
            if link is None:
                return "no session is running", -1
            running = LoopLink.running(link.web_copy())
            if running != "running" and name not in UNGUARDED:
                return f"the session is {running}: commands go once its loop runs", -1
            rid = self.next_id
            self.next_id += 1
            self.requests[rid] = {"received": time.time(), "click_to_come": click_to_come,
                                  **({} if clicked_at is None else {"clicked_at": clicked_at})}
        link.web_send(int(COMMANDS[name]), rid)
        return "", rid

    def estop(self, clicked_at: float | None = None, click_to_come: bool = False
              ) -> tuple[str, int]:
        """Queue an E-stop before anything else (nothing about the request is needed):
        ('' or why it could not go -- no session --, its request id). With
        ``click_to_come`` the request's body (the page's click time) is read after it went
        and :meth:`clicked` must follow."""
        return self.send("estop", clicked_at, click_to_come)

    def clicked(self, rid: int, clicked_at: float | None) -> None:
        """The click time (s, wall clock; None: the page sent none) of E-stop ``rid``, read
        after it went: kept for its applied record, or that record -- held, since the loop
        may apply the E-stop before the request's body is read -- logged with it now."""
        with self.lock:
            req = self.requests.get(rid)
            if req is not None:  # not applied yet
                req["click_to_come"] = False
                if clicked_at is not None:
                    req["clicked_at"] = clicked_at
                return
            held = self.held.pop(rid, None)
            if held is None:
                return
            args, kwargs = held
            if clicked_at is not None:
                kwargs["after_click_ms"] = round((kwargs["applied"] - clicked_at) * 1e3, 3)
            self.record(*args, **kwargs)
