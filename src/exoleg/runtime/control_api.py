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
  "reset" | "impedance" | "transparent" | "aan"}`` (the last three: the walking
  controller's support mode): needs ``Authorization: Bearer <token>`` (printed at start-up) and the
  operator id -- except ``estop``, which anyone who can see the device may send; answers
  once the loop has applied it (``"applied": true``), or 409 with the supervisor's
  reason when it refused it (``"applied": false``: arm in FAULT, walk while disarmed...);
* ``POST /estop``: the E-stop, queued before anything of the request is read (any body,
  any size; an optional ``{"clicked_at": ms}`` is read after, at most
  :data:`BODY_LIMIT` bytes, and a wrong one is logged as ignored);
* ``GET /gains``: the gains in force and the bounds a change must keep (each gain 0 to
  twice its value at the session's start, the support level and assist-as-needed's
  bounds 0-1, the transparent law's inertia share and acceleration estimate within the
  bounds the session sets from its gears' modes); ``POST /gains`` ``{"kp_stance": [hip,
  knee, ankle], ...}`` (any of ``kp_stance``, ``kd_stance``, ``kp_swing``,
  ``kd_swing``, ``support``, ``support_min``, ``support_max``, ``inertia_share``,
  ``accel_filter_hz``): token and operator; a value outside its bounds, or a minimum
  above its maximum, is refused with the reason (422);
* ``GET /log`` (token): every control action of this session (time, source, command,
  accepted or why not), and when the loop applied each command.

Every control action is appended to ``control.log`` (JSON lines) in the session's folder
with its wall time and source; the loop's application of each command is logged with the
time from the request (and from the click, when the page sends ``clicked_at``).
"""

from __future__ import annotations

import asyncio
import json
import math
import threading
import time
from typing import Any

from exoleg.entry import typed_number
from exoleg.params.records import JOINTS
from exoleg.runtime.link import GAIN_NAMES
from exoleg.runtime.operator import COMMANDS, LEASE_S, NO_TOKEN, UNGUARDED, OperatorRules

#: the WebSocket stream's rate, Hz
STREAM_HZ = 50.0
#: The server's event loop not turning for this long is a hung server: the heartbeat
#: stops and the loop, after :data:`~exoleg.runtime.link.LINK_TIMEOUT_S`, brings the
#: device to a stop. A burst of 2,000 requests on 50 connections during a walk delayed
#: its turns by at most 0.034-0.048 s here (``server_stall_max_s``,
#: tests/test_hmi_safety.py);
#: a dead or frozen process stops the heartbeat at once.
EVENT_LOOP_STALL_S = 3.0
#: how long ``POST /command`` waits for the supervisor's answer, s (the loop applies a
#: command at its next tick, 1 ms at 1 kHz; its answer is logged within 5 ms)
APPLIED_WAIT_S = 0.5


def source_of(request: Any) -> str:
    """Who sent ``request``: address and port."""
    c = request.client
    return f"{c.host}:{c.port}" if c else "?"


#: The most of a request's body the API reads, bytes (a command or a gain change is well
#: under 1 KiB).
BODY_LIMIT = 16 * 1024


async def read_body(request: Any) -> tuple[dict[str, Any], str]:
    """The request's JSON object, reading at most :data:`BODY_LIMIT` bytes, and what was
    wrong with it ('' when nothing): over the limit, not JSON, not an object."""
    data = bytearray()
    async for chunk in request.stream():
        data += chunk
        if len(data) > BODY_LIMIT:
            return {}, f"body over {BODY_LIMIT} bytes, not read"
    try:
        body = json.loads(bytes(data) or b"{}")
    except (ValueError, RecursionError):
        return {}, "body is not JSON"
    return (body, "") if isinstance(body, dict) else ({}, "body is not a JSON object")


class BadBody(Exception):
    """A request's body the API cannot take: ``status`` (413 too large, 400 not a JSON
    object) and what was wrong."""

    def __init__(self, status: int, problem: str) -> None:
        super().__init__(problem)
        self.status, self.problem = status, problem


async def body_of(request: Any) -> dict[str, Any]:
    """The request's JSON object; :class:`BadBody` when it is too large or not one
    (answered as JSON by :func:`bad_body`)."""
    body, problem = await read_body(request)
    if problem:
        raise BadBody(413 if "over" in problem else 400, problem)
    return body


async def bad_body(request: Any, exc: Exception) -> Any:
    from starlette.responses import JSONResponse

    assert isinstance(exc, BadBody)
    return JSONResponse({"error": f"{exc.problem} (expected a JSON object of at most "
                                  f"{BODY_LIMIT} bytes)"}, exc.status)


class SameOrigin:
    """ASGI middleware: a POST, PUT or DELETE, or a WebSocket, that a browser sends from
    another page (its ``Origin`` is not this server's, or ``Sec-Fetch-Site`` says
    cross-site) is refused (403) before it reaches a route -- the E-stop included: a page
    elsewhere in the same browser must not move or stop the device, nor read its
    stream. A declared body over :data:`BODY_LIMIT` is refused (413) before it is read,
    except the E-stop's (``/api/estop`` takes any body). Programs (no ``Origin``) pass;
    they need the token for everything but the E-stop."""

    CHANGES = frozenset({"POST", "PUT", "DELETE", "PATCH"})

    def __init__(self, app: Any) -> None:
        self.app = app

    @staticmethod
    def _refusal(scope: dict[str, Any]) -> tuple[int, str]:
        headers = {k.decode("latin-1").lower(): v.decode("latin-1")
                   for k, v in scope.get("headers", [])}
        ws = scope["type"] == "websocket"
        if ws or scope.get("method") in SameOrigin.CHANGES:
            origin = headers.get("origin")
            scheme = {"ws": "http", "wss": "https"}.get(scope.get("scheme", "http"),
                                                        scope.get("scheme", "http"))
            mine = f"{scheme}://{headers.get('host', '')}"
            site = headers.get("sec-fetch-site", "same-origin")
            if (origin is not None and origin != mine) or site not in ("same-origin",
                                                                       "none"):
                return 403, (f"cross-origin request refused: from {origin or site!r}, "
                             f"this interface is {mine} (only its own pages may act)")
        length = headers.get("content-length", "0")
        if scope.get("path") != "/api/estop" and (not length.isdigit()
                                                  or int(length) > BODY_LIMIT):
            return 413, f"body of {length[:20]} bytes refused (at most {BODY_LIMIT})"
        return 0, ""

    async def __call__(self, scope: dict[str, Any], receive: Any, send: Any) -> None:
        if scope["type"] not in ("http", "websocket"):
            return await self.app(scope, receive, send)
        status, why = self._refusal(scope)
        if not status:
            return await self.app(scope, receive, send)
        if scope["type"] == "websocket":
            await send({"type": "websocket.close", "code": 1008, "reason": why[:120]})
            return None
        from starlette.responses import JSONResponse

        return await JSONResponse({"error": why}, status)(scope, receive, send)


def click_stamp(value: Any) -> tuple[float | None, str]:
    """A page's optional click time (ms since the epoch) as s, or None and why it was
    ignored: not a finite number between 0 and 1e13 ms (the year 2286)."""
    if value is None:
        return None, ""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return None, f"clicked_at ignored: not a number ({str(value)[:40]!r})"
    try:
        ms = float(value)
    except OverflowError:
        return None, "clicked_at ignored: too large"
    if not (math.isfinite(ms) and 0.0 < ms < 1e13):
        return None, f"clicked_at ignored: {ms!r} is not a time (0 to 1e13 ms)"
    return ms / 1e3, ""


def loopback(host: str) -> bool:
    return host in ("127.0.0.1", "localhost", "::1") or host.startswith("127.")


class ControlAPI(OperatorRules):
    """The operator rules (:class:`~exoleg.runtime.operator.OperatorRules`) over HTTP:
    the routes, a request's refusal, the watch on applied commands."""

    #: the longest the server's event loop went without turning, s (:meth:`watch`)
    stall_max_s = 0.0

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
            # how long the event loop went without turning, at most, since the server
            # started (s): what a burst of requests costs it
            return JSONResponse({**self.state(), "server_stall_max_s":
                                 round(self.stall_max_s, 4)})

        async def log(request: Request) -> JSONResponse:
            if not self.has_token(request.headers):  # who did what: the session's record
                return JSONResponse({"error": NO_TOKEN}, 401)
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
                self.release(source)  # an armed device nobody controls comes to rest
                with self.lock:
                    alarm = self.alarm
                return JSONResponse({"holder": None, "alarm": alarm})
            body = await body_of(request)
            name = str(body.get("name", "")).strip()[:40] or "operator"
            status, out = self.take(request.headers, source, name)
            return JSONResponse(out, status)

        def estopped(source: str, why: str, note: str) -> JSONResponse:
            """The answer to an E-stop already queued (or refused: no session)."""
            if why:
                self.record(source, "estop", False, why)
                return JSONResponse({"error": why}, 409)
            self.record(source, "estop", True, note)
            return JSONResponse({"queued": "estop"})

        async def estop(request: Request) -> JSONResponse:
            # the E-stop goes before anything of the request is read: any body, any size;
            # the page's click time in it follows (its applied record waits for it)
            why, rid = self.estop(click_to_come=True)
            self.who(request.headers)  # the operator's name in the record, if theirs
            body: dict[str, Any] = {}
            problem = ""
            try:
                if not why:
                    body, problem = await read_body(request)
            finally:
                clicked_at, note = click_stamp(body.get("clicked_at"))
                if not why:
                    self.clicked(rid, clicked_at)
            return estopped(source_of(request), why,
                            "; ".join(x for x in (problem, note) if x))

        async def command(request: Request) -> JSONResponse:
            source = source_of(request)
            body = await body_of(request)
            name = str(body.get("command", ""))
            clicked_at, note = click_stamp(body.get("clicked_at"))
            if name == "estop":
                why, rid = self.estop(clicked_at)
                self.who(request.headers)
                return estopped(source, why, note)
            if name not in COMMANDS:
                why = f"unknown command {name!r} (allowed: {', '.join(COMMANDS)})"
                self.record(source, name or "?", False, why)
                return JSONResponse({"error": why}, 400)
            if name not in UNGUARDED:
                refused = self.refusal(request, name)
                if refused:
                    return refused
            why, rid = self.send(name, clicked_at)
            if why:
                self.record(source, name, False, why)
                return JSONResponse({"error": why}, 409)
            self.record(source, name, True, note)
            # the supervisor's answer, once the loop has applied it (a few ticks)
            deadline = time.monotonic() + APPLIED_WAIT_S
            while (done := self.outcome(rid)) is None and time.monotonic() < deadline:
                await asyncio.sleep(0.002)
            if done is None:
                return JSONResponse({"queued": name, "applied": None})
            if not done[0]:
                return JSONResponse({"error": done[1], "queued": name, "applied": False},
                                    409)
            return JSONResponse({"queued": name, "applied": True})

        async def gains(request: Request) -> JSONResponse:
            if request.method == "GET":
                g, b = self.gains()
                return JSONResponse({"gains": g, "bounds": b})
            source = source_of(request)
            refused = self.refusal(request, "gains")
            if refused:
                return refused
            body = await body_of(request)
            change: dict[str, list[float]] = {}
            why = ""
            try:
                for k, v in body.items():
                    vals = v if isinstance(v, list) else [v]
                    change[str(k)[:40]] = [
                        typed_number(f"{k} ({JOINTS[i]})" if len(vals) == 3 else str(k), x)
                        for i, x in enumerate(vals)]
            except ValueError as e:  # empty, not a number: said in the form's words
                why = str(e)
            why = why or (self.check_gains(change) if change else
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
                Route("/estop", estop, methods=["POST"]),
                WebSocketRoute("/stream", stream)]

    async def watch(self) -> None:
        """Runs beside the server on its event loop for as long as it serves: says every
        5 ms that the event loop turns, and runs the watch (:meth:`watch_once`: the
        heartbeat, the commands applied, the holds) in a thread of its own, so that a
        burst of requests, which delays the event loop's turns, never starves the
        heartbeat; an event loop that has not turned for :data:`EVENT_LOOP_STALL_S` is
        hung, and the heartbeat stops (a lost link, as when the process dies or freezes)."""
        stop = threading.Event()
        self._turned = time.monotonic()
        self.stall_max_s = 0.0

        def beat() -> None:
            # the watch beats first; what fails after it (a copy of the shared block torn
            # past its retries by a loop the OS stopped mid-write) is said once in the
            # log, and the watch goes on: a thread ended by it would leave every later
            # session of this server unbeaten (each then lost 1 s into its loop)
            said = ""
            while not stop.wait(0.005):
                try:
                    self.watch_once(
                        beat=time.monotonic() - self._turned < EVENT_LOOP_STALL_S)
                except Exception as e:
                    text = f"{type(e).__name__}: {e}"
                    if text != said:
                        said = text
                        self.record("hmi", "watch failed", False,  # (no copy needed)
                                    why=f"{text} (the heartbeat goes on)",
                                    log=self.log_path("session"))

        watcher = threading.Thread(target=beat, name="exoleg-heartbeat", daemon=True)
        watcher.start()
        try:
            while True:
                now = time.monotonic()
                self.stall_max_s = max(self.stall_max_s, now - self._turned)
                self._turned = now
                await asyncio.sleep(0.005)
        finally:
            stop.set()
