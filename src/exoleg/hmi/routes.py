"""The operator interface's web app over an :class:`~exoleg.hmi.server.HMI`: the pages
(``exoleg/hmi/static``), the child's fit and kept record, starting and ending sessions and
identifications, the recorded sessions and their files, and the control API of the
session (:mod:`exoleg.runtime.control_api`) mounted at ``/api``; requests only to
loopback names on loopback, same-origin writes. The children's and sessions' records
need the token; what changes the device, the token and the operator holding control."""

from __future__ import annotations

import contextlib
from pathlib import Path
from typing import Any

from exoleg.control.hierarchy import TUNABLE
from exoleg.entry import typed_number
from exoleg.errors import ParameterError
from exoleg.hmi.server import HMI, MAX_DURATION, PLAN_RANGE
from exoleg.hmi.views import VOCABULARY
from exoleg.runtime.control_api import BadBody, SameOrigin, bad_body, body_of, loopback, source_of

#: the pages and their assets, shipped in the package
STATIC = Path(__file__).parent / "static"


def request_id(body: dict[str, Any]) -> str | None:
    """A start's ``request`` id (the page's, 1-64 letters, digits, ``-`` or ``_``;
    None when not given). ValueError naming the field when it is anything else."""
    rid = body.get("request")
    if rid is None:
        return None
    if not (isinstance(rid, str) and 1 <= len(rid) <= 64
            and all(ch.isascii() and (ch.isalnum() or ch in "-_") for ch in rid)):
        raise ValueError(f"request: {rid!r} is not a start's id (1-64 letters, digits, "
                         "- or _)")
    return rid


def app(hmi: HMI) -> Any:
    """The Starlette app serving ``hmi``."""
    from starlette.applications import Starlette
    from starlette.concurrency import run_in_threadpool
    from starlette.requests import Request
    from starlette.responses import FileResponse, JSONResponse, Response
    from starlette.routing import Mount, Route
    from starlette.staticfiles import StaticFiles

    api = hmi.api

    async def index(request: Request) -> Response:
        return FileResponse(STATIC / "index.html")

    def private(request: Request) -> JSONResponse | None:
        """None with the token; else the refusal (children's and sessions' data)."""
        if api.has_token(request.headers):
            return None
        return JSONResponse({"error": "the children's and the sessions' records need "
                             "the token (Control page: Token)"}, 401)

    async def info(request: Request) -> JSONResponse:
        records = private(request) is None
        with hmi.lock:
            kept, runs_on = hmi.kept, hmi.runs_on()
            out = {"device": hmi.info, "backend": hmi.backend, "fixed": hmi.fixed,
                   "simulated": hmi._simulated(),
                   "session": hmi.session.name if hmi.session else None,
                   "max_duration": MAX_DURATION, "vocabulary": VOCABULARY,
                   "gains": [g for g in TUNABLE if g != "support"],
                   "records": records}
        if records:
            reg = hmi.registry
            out.update(child=kept and {**kept["record"], "child_id": kept["child_id"],
                                       "fit_id": kept["id"]},
                       runs_on=runs_on["text"],
                       children=[] if reg is None else reg.children(),
                       damaged=[] if reg is None else reg.damaged)
        return JSONResponse(out)

    async def child_history_route(request: Request) -> JSONResponse:
        refused = private(request)
        if refused:
            return refused
        from exoleg.hmi.history import child_history

        try:
            return JSONResponse(await run_in_threadpool(
                child_history, hmi.root, request.path_params["child_id"]))
        except ParameterError as e:
            return JSONResponse({"error": str(e)}, 404)

    async def keep_child(request: Request) -> JSONResponse:
        refused = api.refusal(request, "keep child")
        if refused:
            return refused
        status, out = await run_in_threadpool(
            hmi.keep_child, request.path_params["child_id"], source_of(request))
        return JSONResponse(out, status)

    async def fit(request: Request) -> JSONResponse:
        refused = api.refusal(request, "fit")
        if refused:
            return refused
        body = await body_of(request)
        status, out = await run_in_threadpool(hmi.fit, body, source_of(request))
        return JSONResponse(out, status)

    async def started(request: Request, what: str, field: str, default: float,
                      identify: bool) -> JSONResponse:
        """A session's start (``identify``: identification's), its length the body's
        ``field`` (``default`` when not given), its id the body's ``request``."""
        refused = api.refusal(request, what)
        if refused:
            return refused
        body = await body_of(request)
        try:
            length = typed_number(f"{field.capitalize()} (s)", body.get(field, default))
            started_by = request_id(body)
        except ValueError as e:
            api.record(source_of(request), what, False, str(e))
            return JSONResponse({"error": str(e)}, 422)
        # off the event loop: a start may wait for the last session's records
        status, out = await run_in_threadpool(hmi.start, length, source_of(request),
                                              arm=body.get("arm") is True,
                                              identify=identify, request=started_by)
        if status != 200:
            api.record(source_of(request), what, False, out["error"])
        return JSONResponse(out, status)

    async def session_start(request: Request) -> JSONResponse:
        return await started(request, "start session", "duration", 60.0, False)

    async def identify_start(request: Request) -> JSONResponse:
        return await started(request, "start identification", "plan", PLAN_RANGE[1], True)

    async def session_note(request: Request) -> JSONResponse:
        refused = api.refusal(request, "note")
        if refused:
            return refused
        body = await body_of(request)
        status, out = hmi.note(body.get("note"), source_of(request))
        return JSONResponse(out, status)

    async def session_end(request: Request) -> JSONResponse:
        refused = api.refusal(request, "end session")
        if refused:
            return refused
        status, out = hmi.end(source_of(request))
        return JSONResponse(out, status)

    async def sessions(request: Request) -> JSONResponse:
        refused = private(request)
        if refused:
            return refused
        return JSONResponse(await run_in_threadpool(hmi.sessions))

    def recorded(request: Request) -> Path | Response:
        """The recorded session's folder the path names, or the answer refusing it (the
        records need the token; a name not recorded: 404)."""
        refused = private(request)
        if refused:
            return refused
        name = request.path_params["name"]
        folder = hmi.archive.folder_of(name)
        if folder is None:
            return JSONResponse({"error": f"no recorded session {name!r}"}, 404)
        return folder

    async def session_detail(request: Request) -> Response:
        folder = recorded(request)
        if not isinstance(folder, Path):
            return folder
        return JSONResponse(await run_in_threadpool(hmi.archive.detail, folder,
                                                    hmi.live()))

    async def session_file(request: Request) -> Response:
        folder = recorded(request)
        if not isinstance(folder, Path):
            return folder
        kind = request.path_params["kind"]
        try:
            if kind == "plot.png":
                path = await run_in_threadpool(hmi.archive.plot, folder)
                return FileResponse(path, media_type="image/png")
            if kind == "report.pdf":
                path = await run_in_threadpool(hmi.archive.report, folder)
                return FileResponse(path, filename=f"{folder.name}-report.pdf",
                                    media_type="application/pdf")
            if kind == "session.c3d":
                path = await run_in_threadpool(hmi.archive.c3d, folder)
                return FileResponse(path, filename=path.name.replace(
                    "session", folder.name))
            if kind in ("session.csv", "session.parquet"):
                fmt = kind.split(".")[1]
                path = await run_in_threadpool(hmi.archive.export, folder, fmt)
                return FileResponse(path, filename=f"{folder.name}.{fmt}")
        except (ParameterError, OSError) as e:
            return JSONResponse({"error": f"session {folder.name}: {e}"}, 409)
        return JSONResponse({"error": f"unknown file {kind!r} (allowed: plot.png, "
                                      "report.pdf, session.c3d, session.csv, "
                                      "session.parquet)"}, 404)

    @contextlib.asynccontextmanager
    async def lifespan(app: Any) -> Any:
        import asyncio

        task = asyncio.create_task(api.watch())
        yield
        task.cancel()

    routes = [Route("/", index), Route("/api/info", info),
              Route("/api/fit", fit, methods=["POST"]),
              Route("/api/session/start", session_start, methods=["POST"]),
              Route("/api/identify/start", identify_start, methods=["POST"]),
              Route("/api/session/end", session_end, methods=["POST"]),
              Route("/api/session/note", session_note, methods=["POST"]),
              Route("/api/children/{child_id}/history", child_history_route),
              Route("/api/children/{child_id}/keep", keep_child, methods=["POST"]),
              Route("/api/sessions", sessions),
              Route("/api/sessions/{name}", session_detail),
              Route("/api/sessions/{name}/{kind}", session_file),
              Mount("/api", routes=api.routes()),
              Mount("/static", app=StaticFiles(directory=STATIC), name="static")]
    from starlette.middleware import Middleware
    from starlette.middleware.trustedhost import TrustedHostMiddleware

    # on loopback, only requests addressed to loopback names: a page elsewhere that
    # rebinds its own name to 127.0.0.1 cannot read the state
    hosts = (["127.0.0.1", "localhost", "[::1]", hmi.host] if loopback(hmi.host)
             else ["*"])
    return Starlette(routes=routes, lifespan=lifespan,
                     exception_handlers={BadBody: bad_body},
                     middleware=[Middleware(TrustedHostMiddleware, allowed_hosts=hosts),
                                 Middleware(SameOrigin)])
