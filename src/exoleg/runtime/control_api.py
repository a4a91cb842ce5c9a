"""The runtime's control API: a local HTTP/WebSocket interface to a running session, for
the operator interface (issue 13 builds on it) and for scripts.

Served by uvicorn (Starlette) from a thread beside the loop, on 127.0.0.1 unless an
explicit host is given (the CLI then prints a warning: the API carries no TLS). The
loop never waits for it: the API reads the latest snapshot the loop published and
leaves commands in a queue the loop takes one per tick.

Endpoints (JSON):

* ``GET /state``: the latest tick -- time, mode, phase, events, safety status, measured
  joint angles (rad), commanded torques (N m), FSR counts, lateness (us);
* ``GET /stream`` (WebSocket): the same at up to 50 Hz;
* ``POST /command`` ``{"command": "arm" | "stand" | "walk" | "disarm" | "estop" |
  "reset"}``: needs ``Authorization: Bearer <token>`` (printed when the session starts)
  -- except ``estop``, which anyone who can see the device may send;
* ``GET /gains``: the walking controller's gains now and the bounds a change must keep
  (each gain 0 to twice its configured value, the support level 0-1);
* ``POST /gains`` ``{"kp_stance": [hip, knee, ankle], ...}`` (any of ``kp_stance``,
  ``kd_stance``, ``kp_swing``, ``kd_swing``, ``support``): needs the token; a value
  outside its bounds is refused with the reason (422); accepted changes act from the
  next tick;
* ``GET /log``: every control action so far (time, source, command, accepted or why not).

Every control action is also appended to ``control.log`` (JSON lines) beside the session
log, with its time and source.
"""

from __future__ import annotations

import json
import queue
import secrets
import threading
import time
from pathlib import Path
from typing import Any

from exoleg.control.hierarchy import Command

COMMANDS = {"arm": Command.ARM, "stand": Command.STAND, "walk": Command.WALK,
            "disarm": Command.DISARM, "estop": Command.ESTOP, "reset": Command.RESET}
#: commands anyone may send (no token): stopping the device
UNGUARDED = {"estop"}


class ControlAPI:
    """The API's state between the loop and the web server (thread-safe)."""

    def __init__(self, folder: str | Path, token: str | None = None) -> None:
        self.token = token or secrets.token_urlsafe(16)
        self.gains: dict[str, list[float]] = {}   # now (set by the session)
        self.bounds: dict[str, list[list[float]]] = {}
        self.gain_changes: queue.Queue[dict[str, list[float]]] = queue.Queue()
        self.snapshot: dict[str, Any] = {}
        self.lock = threading.Lock()
        self.commands: queue.Queue[tuple[int, str]] = queue.Queue()
        self.actions: list[dict[str, Any]] = []
        self.log_path = Path(folder) / "control.log"
        self.server: Any = None
        self.thread: threading.Thread | None = None

    # ---------------------------------------------------------------- the loop's side
    def publish(self, state: dict[str, Any]) -> None:
        with self.lock:
            self.snapshot = state

    def set_gains(self, gains: dict[str, list[float]]) -> None:
        """The controller's gains now; the bounds are set from the first call."""
        with self.lock:
            self.gains = {k: list(v) for k, v in gains.items()}
            if not self.bounds:
                self.bounds = {k: [[0.0, 1.0]] * len(v) if k == "support" else
                               [[0.0, 2.0 * x] for x in v] for k, v in gains.items()}

    def next_gains(self) -> dict[str, list[float]] | None:
        try:
            return self.gain_changes.get_nowait()
        except queue.Empty:
            return None

    def next_command(self) -> int:
        """The oldest queued command (0: none), one per tick."""
        try:
            return int(self.commands.get_nowait()[0])
        except queue.Empty:
            return 0

    # ---------------------------------------------------------------- the web side
    def _record(self, source: str, command: str, accepted: bool, why: str = "") -> None:
        entry = {"time": time.time(), "source": source, "command": command,
                 "accepted": accepted, **({"why": why} if why else {})}
        with self.lock:
            self.actions.append(entry)
        with self.log_path.open("a") as f:
            f.write(json.dumps(entry) + "\n")

    def app(self) -> Any:
        from starlette.applications import Starlette
        from starlette.requests import Request
        from starlette.responses import JSONResponse
        from starlette.routing import Route, WebSocketRoute
        from starlette.websockets import WebSocket, WebSocketDisconnect

        async def state(request: Request) -> JSONResponse:
            with self.lock:
                return JSONResponse(self.snapshot)

        async def log(request: Request) -> JSONResponse:
            with self.lock:
                return JSONResponse(self.actions)

        async def command(request: Request) -> JSONResponse:
            source = request.client.host if request.client else "?"
            try:
                body = await request.json()
                name = str(body["command"])
            except (ValueError, KeyError, TypeError):
                self._record(source, "?", False, "bad request")
                return JSONResponse({"error": "expected JSON {\"command\": ...} (allowed: "
                                     + ", ".join(COMMANDS) + ")"}, status_code=400)
            if name not in COMMANDS:
                self._record(source, name, False, "unknown command")
                return JSONResponse({"error": f"unknown command {name!r} (allowed: "
                                     + ", ".join(COMMANDS) + ")"}, status_code=400)
            auth = request.headers.get("authorization", "")
            if name not in UNGUARDED and not secrets.compare_digest(
                    auth, f"Bearer {self.token}"):
                self._record(source, name, False, "no valid token")
                return JSONResponse({"error": "this command needs the session's token "
                                     "(Authorization: Bearer ...)"}, status_code=401)
            self.commands.put((int(COMMANDS[name]), source))
            self._record(source, name, True)
            return JSONResponse({"queued": name})

        async def gains(request: Request) -> JSONResponse:
            if request.method == "GET":
                with self.lock:
                    return JSONResponse({"gains": self.gains, "bounds": self.bounds})
            source = request.client.host if request.client else "?"
            auth = request.headers.get("authorization", "")
            if not secrets.compare_digest(auth, f"Bearer {self.token}"):
                self._record(source, "gains", False, "no valid token")
                return JSONResponse({"error": "changing gains needs the session's token"},
                                    status_code=401)
            try:
                body = await request.json()
                change = {str(k): [float(x) for x in (v if isinstance(v, list) else [v])]
                          for k, v in dict(body).items()}
            except (ValueError, TypeError):
                self._record(source, "gains", False, "bad request")
                return JSONResponse({"error": "expected JSON {name: [hip, knee, ankle]}"},
                                    status_code=400)
            with self.lock:
                bounds = dict(self.bounds)
            for k, v in change.items():
                if k not in bounds:
                    why = f"unknown gain {k!r} (allowed: {', '.join(bounds)})"
                elif len(v) != len(bounds[k]):
                    why = f"{k}: expected {len(bounds[k])} values, got {len(v)}"
                else:
                    why = next((f"{k}[{i}] = {x:g} is outside {lo:g}-{hi:g}"
                                for i, (x, (lo, hi)) in enumerate(zip(v, bounds[k],
                                                                      strict=True))
                                if not (lo <= x <= hi)), "")
                if why:
                    self._record(source, f"gains {k}", False, why)
                    return JSONResponse({"error": why, "bounds": bounds}, status_code=422)
            self.gain_changes.put(change)
            self._record(source, "gains " + ", ".join(change), True)
            return JSONResponse({"queued": change})

        async def stream(ws: WebSocket) -> None:
            import asyncio

            await ws.accept()
            try:
                while True:
                    with self.lock:
                        snap = dict(self.snapshot)
                    await ws.send_json(snap)
                    await asyncio.sleep(0.02)
            except (WebSocketDisconnect, RuntimeError):
                return

        return Starlette(routes=[Route("/state", state), Route("/log", log),
                                 Route("/gains", gains, methods=["GET", "POST"]),
                                 Route("/command", command, methods=["POST"]),
                                 WebSocketRoute("/stream", stream)])

    def start(self, host: str = "127.0.0.1", port: int = 8765) -> None:
        """Serve from a daemon thread; returns once the server is listening."""
        import uvicorn

        config = uvicorn.Config(self.app(), host=host, port=port, log_level="warning",
                                lifespan="off")
        self.server = uvicorn.Server(config)
        self.thread = threading.Thread(target=self.server.run, daemon=True)
        self.thread.start()
        deadline = time.time() + 10
        while not self.server.started and time.time() < deadline:
            time.sleep(0.01)

    def stop(self) -> None:
        if self.server is not None:
            self.server.should_exit = True
        if self.thread is not None:
            self.thread.join(timeout=5)
