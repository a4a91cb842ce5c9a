"""The runtime's control API: the web side of a session, for the operator interface
(:mod:`exoleg.hmi`) and for scripts.

It runs in the web server's process, never in the loop's: it reads the loop's shared
block and sends into its pipe (:class:`~exoleg.runtime.link.LoopLink`). Endpoints (JSON):

* ``GET /state``: the latest tick (published at 100 Hz) -- time, mode, phase, events and
  safety bits since the last publication, measured joint angles and speeds (rad, rad/s),
  the reference (rad), commanded torques (N m), FSR counts, loop lateness (us: this tick,
  the worst since the last publication, deadlines missed so far), ``running``;
* ``GET /stream`` (WebSocket): the same at 50 Hz;
* ``GET /operator``: who holds control; ``POST /operator`` ``{"name": ...}`` (token) takes
  it -- refused while another operator holds it -- and returns the operator id every
  control action then carries (``X-Operator``); the hold lapses after
  :data:`LEASE_S` s without a request from it; ``DELETE /operator`` gives it back;
* ``POST /command`` ``{"command": "arm" | "stand" | "walk" | "disarm" | "estop" |
  "reset"}``: needs ``Authorization: Bearer <token>`` (printed at start-up) and the
  operator id -- except ``estop``, which anyone who can see the device may send;
* ``GET /gains``: the gains in force and the bounds a change must keep (each gain 0 to
  twice its value at the session's start, the support level 0-1); ``POST /gains``
  ``{"kp_stance": [hip, knee, ankle], ...}`` (any of ``kp_stance``, ``kd_stance``,
  ``kp_swing``, ``kd_swing``, ``support``): token and operator; a value outside its
  bounds is refused with the reason (422);
* ``GET /log``: every control action of this session (time, source, command, accepted
  or why not), and when the loop applied each command.

Every control action is appended to ``control.log`` (JSON lines) in the session's folder
with its wall time and source; the loop's application of each command is logged with the
time from the request (and from the click, when the page sends ``clicked_at``).
"""

from __future__ import annotations

import asyncio
import json
import secrets
import threading
import time
from pathlib import Path
from typing import Any

from exoleg.control.contract import Command
from exoleg.runtime.link import GAIN_NAMES, LoopLink

COMMANDS = {"arm": Command.ARM, "stand": Command.STAND, "walk": Command.WALK,
            "disarm": Command.DISARM, "estop": Command.ESTOP, "reset": Command.RESET}
NAMES = {int(v): k for k, v in COMMANDS.items()}
#: commands anyone may send (no token, no operator): stopping the device
UNGUARDED = {"estop"}
#: an operator's hold on control lapses after this long without a request from them, s
LEASE_S = 5.0
STREAM_HZ = 50.0
NO_TOKEN = "no valid token (Authorization: Bearer <the token printed at start-up>)"


def source_of(request: Any) -> str:
    """Who sent ``request``: address and port."""
    c = request.client
    return f"{c.host}:{c.port}" if c else "?"


async def body_of(request: Any) -> dict[str, Any]:
    """The request's JSON object ({} when it is not one)."""
    try:
        body = await request.json()
    except ValueError:
        return {}
    return body if isinstance(body, dict) else {}


def loopback(host: str) -> bool:
    return host in ("127.0.0.1", "localhost", "::1") or host.startswith("127.")


class ControlAPI:
    """The web side's state: the session attached, the operator holding control, the
    actions logged. Thread-safe (the server's event loop and the HMI's threads)."""

    def __init__(self, token: str | None = None, folder: str | Path = ".") -> None:
        self.token = token or secrets.token_urlsafe(16)
        self.lock = threading.RLock()
        self.link: LoopLink | None = None
        self.folder = Path(folder)  # where control.log goes
        self.bounds: dict[str, list[list[float]]] = {}
        self.actions: list[dict[str, Any]] = []
        self.operator: dict[str, Any] | None = None
        self.requests: dict[int, dict[str, Any]] = {}
        self.next_id = 1
        self.seen_applied = 0

    @property
    def log_path(self) -> Path:
        return self.folder / "control.log"

    def attach(self, link: LoopLink, folder: str | Path) -> None:
        """A session starts: its link and its folder (control.log)."""
        with self.lock:
            self.link, self.folder = link, Path(folder)
            self.bounds, self.actions, self.requests = {}, [], {}
            self.seen_applied = 0

    def detach(self) -> None:
        with self.lock:
            self.link = None

    # ------------------------------------------------------------------ bookkeeping
    def record(self, source: str, command: str, accepted: bool, why: str = "",
               **extra: Any) -> dict[str, Any]:
        entry = {"time": time.time(), "source": source, "command": command,
                 "accepted": accepted, **({"why": why} if why else {}), **extra}
        with self.lock:
            self.actions.append(entry)
            try:
                with self.log_path.open("a") as f:
                    f.write(json.dumps(entry) + "\n")
            except OSError as e:  # the action stands; the failure is said where it is seen
                entry["log_error"] = str(e)
        return entry

    def state(self) -> dict[str, Any]:
        with self.lock:
            link = self.link
        if link is None:
            return {"running": "none"}
        return LoopLink.snapshot(link.web_copy())

    def gains(self) -> tuple[dict[str, list[float]], dict[str, list[list[float]]]]:
        """The gains in force and their bounds (set from the first gains the session
        published); empty before the session has started."""
        with self.lock:
            link = self.link
        if link is None:
            return {}, {}
        g = LoopLink.gains(link.web_copy())
        if g is None:  # not yet published by the session
            return {}, {}
        with self.lock:
            if not self.bounds:
                self.bounds = {k: [[0.0, 1.0]] * len(v) if k == "support" else
                               [[0.0, 2.0 * x] for x in v] for k, v in g.items()}
            return g, dict(self.bounds)

    def check_gains(self, change: dict[str, list[float]]) -> str:
        """Why ``change`` is refused ('' when it is within bounds)."""
        _, bounds = self.gains()
        if not bounds:
            return "no session is running"
        for k, v in change.items():
            if k not in bounds:
                return f"unknown gain {k!r} (allowed: {', '.join(GAIN_NAMES)})"
            if len(v) != len(bounds[k]):
                return f"{k}: expected {len(bounds[k])} values, got {len(v)}"
            for i, (x, (lo, hi)) in enumerate(zip(v, bounds[k], strict=True)):
                if not lo <= x <= hi:
                    return f"{k}[{i}] = {x:g} is outside {lo:g}-{hi:g}"
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
            for code, rid, tick, wall in done:
                req = self.requests.pop(rid, {})
                extra: dict[str, Any] = {"tick": tick, "request": rid}
                if "received" in req:
                    extra["after_request_ms"] = round((wall - req["received"]) * 1e3, 3)
                if "clicked_at" in req:
                    extra["after_click_ms"] = round((wall - req["clicked_at"]) * 1e3, 3)
                self.record("loop", NAMES.get(code, str(code)), True, applied=wall, **extra)

    # ------------------------------------------------------------------ control
    def holder(self) -> dict[str, Any] | None:
        with self.lock:
            op = self.operator
            if op is not None and time.time() - op["seen"] > LEASE_S:
                self.operator = op = None
            return op

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
                why = "take control first (POST /operator): no operator holds it"
            elif not secrets.compare_digest(oid, op["id"]):
                why = (f"control is held by {op['name']} ({op['source']}); you can view "
                       "only")
            else:
                with self.lock:
                    op["seen"] = time.time()
        if why:
            self.record(source, what, False, why)
        return why

    def take(self, headers: Any, source: str, name: str) -> tuple[int, dict[str, Any]]:
        if not self.has_token(headers):
            self.record(source, f"take control ({name})", False, NO_TOKEN)
            return 401, {"error": NO_TOKEN}
        with self.lock:
            op = self.holder()
            if op is not None and op["id"] != headers.get("x-operator", ""):
                why = (f"control is held by {op['name']} ({op['source']}) since "
                       f"{time.strftime('%H:%M:%S', time.localtime(op['since']))}; you can "
                       "view only")
                self.record(source, f"take control ({name})", False, why)
                return 409, {"error": why, "holder": self.public(op)}
            now = time.time()
            self.operator = op = {"id": secrets.token_urlsafe(12), "name": name,
                                  "source": source, "since": now, "seen": now}
        self.record(source, f"take control ({name})", True)
        return 200, {"operator": op["id"], "holder": self.public(op)}

    @staticmethod
    def public(op: dict[str, Any] | None) -> dict[str, Any] | None:
        return None if op is None else {k: op[k] for k in ("name", "source", "since")}

    def send(self, name: str, source: str, clicked_at: float | None = None) -> str:
        """Queue ``name`` for the loop; '' or why it cannot go."""
        with self.lock:
            link = self.link
            if link is None:
                return "no session is running"
            running = LoopLink.running(link.web_copy())
            if running != "running" and name not in UNGUARDED:
                return f"the session is {running}: commands go once its loop runs"
            rid = self.next_id
            self.next_id += 1
            self.requests[rid] = {"received": time.time(), **(
                {"clicked_at": clicked_at} if clicked_at is not None else {})}
        link.web_send(int(COMMANDS[name]), rid)
        return ""

    def refusal(self, request: Any, what: str) -> Any:
        """None when ``request`` may do ``what`` (:meth:`authorise`); else the refusal to
        send (401 without the token, 409 without control)."""
        from starlette.responses import JSONResponse

        why = self.authorise(request.headers, source_of(request), what)
        if not why:
            return None
        return JSONResponse({"error": why}, 401 if "token" in why else 409)

    # ------------------------------------------------------------------ the routes
    def routes(self) -> list[Any]:
        from starlette.requests import Request
        from starlette.responses import JSONResponse
        from starlette.routing import Route, WebSocketRoute
        from starlette.websockets import WebSocket, WebSocketDisconnect

        async def state(request: Request) -> JSONResponse:
            return JSONResponse(self.state())

        async def log(request: Request) -> JSONResponse:
            with self.lock:
                return JSONResponse(list(self.actions))

        async def operator(request: Request) -> JSONResponse:
            source = source_of(request)
            if request.method == "GET":
                op = self.holder()
                mine = op is not None and request.headers.get("x-operator") == op["id"]
                if mine and op is not None:
                    with self.lock:
                        op["seen"] = time.time()
                return JSONResponse({"holder": self.public(op), "you": mine,
                                     "lease_s": LEASE_S})
            if request.method == "DELETE":
                refused = self.refusal(request, "give up control")
                if refused:
                    return refused
                with self.lock:
                    self.operator = None
                self.record(source, "give up control", True)
                return JSONResponse({"holder": None})
            body = await body_of(request)
            name = str(body.get("name", "")).strip()[:40] or "operator"
            status, out = self.take(request.headers, source, name)
            return JSONResponse(out, status)

        async def command(request: Request) -> JSONResponse:
            source = source_of(request)
            body = await body_of(request)
            name = str(body.get("command", ""))
            if name not in COMMANDS:
                why = f"unknown command {name!r} (allowed: {', '.join(COMMANDS)})"
                self.record(source, name or "?", False, why)
                return JSONResponse({"error": why}, 400)
            if name not in UNGUARDED:
                refused = self.refusal(request, name)
                if refused:
                    return refused
            clicked = body.get("clicked_at")
            clicked_at = float(clicked) / 1e3 if isinstance(clicked, (int, float)) else None
            why = self.send(name, source, clicked_at)
            if why:
                self.record(source, name, False, why)
                return JSONResponse({"error": why}, 409)
            self.record(source, name, True)
            return JSONResponse({"queued": name})

        async def gains(request: Request) -> JSONResponse:
            if request.method == "GET":
                g, b = self.gains()
                return JSONResponse({"gains": g, "bounds": b})
            source = source_of(request)
            refused = self.refusal(request, "gains")
            if refused:
                return refused
            body = await body_of(request)
            try:
                change = {str(k): [float(x) for x in (v if isinstance(v, list) else [v])]
                          for k, v in body.items()}
            except (ValueError, TypeError):
                change = {}
            why = (self.check_gains(change) if change else
                   "expected JSON {name: [hip, knee, ankle]} (names: "
                   + ", ".join(GAIN_NAMES) + ")")
            if why:
                self.record(source, "gains " + ", ".join(change), False, why)
                return JSONResponse({"error": why, "bounds": self.gains()[1]}, 422)
            with self.lock:
                link = self.link
            if link is not None:
                link.web_gains(change)
            self.record(source, "gains " + json.dumps(change), True)
            return JSONResponse({"queued": change})

        async def stream(ws: WebSocket) -> None:
            await ws.accept()
            try:
                while True:
                    await ws.send_json(self.state())
                    await asyncio.sleep(1.0 / STREAM_HZ)
            except (WebSocketDisconnect, RuntimeError, OSError):
                return

        return [Route("/state", state), Route("/log", log),
                Route("/operator", operator, methods=["GET", "POST", "DELETE"]),
                Route("/gains", gains, methods=["GET", "POST"]),
                Route("/command", command, methods=["POST"]),
                WebSocketRoute("/stream", stream)]

    async def watch_applied(self) -> None:
        """Runs beside the server: logs the loop's application of each command."""
        while True:
            self.poll_applied()
            await asyncio.sleep(0.005)
