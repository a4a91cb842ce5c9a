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
import time
from typing import Any

from exoleg.runtime.link import GAIN_NAMES
from exoleg.runtime.operator import COMMANDS, LEASE_S, UNGUARDED, OperatorRules

#: the WebSocket stream's rate, Hz
STREAM_HZ = 50.0


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


class ControlAPI(OperatorRules):
    """The operator rules (:class:`~exoleg.runtime.operator.OperatorRules`) over HTTP:
    the routes, a request's refusal, the watch on applied commands."""

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
