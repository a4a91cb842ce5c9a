"""The operator interface's server: the pages (shipped in ``exoleg/hmi/static``, no
internet needed), the control API of the session (:mod:`exoleg.runtime.control_api`),
the child's fitting, starting and ending sessions, and the recorded sessions.

Processes: the web server never shares a process with a 1 kHz loop. Under ``exoleg hmi``
the server is the main process and each session runs in a process of its own, started
from the *Control* page; under ``exoleg run --hmi`` the command's process runs the loop
and the server runs in a child process (:func:`start_process`). Both talk through a
:class:`~exoleg.runtime.link.LoopLink`. The server keeps off the loop's CPU
(:func:`keep_off_loop_cpu`); a session's process takes back the CPUs the server had.

Every request that changes what the device does -- take control, keep a child's fit,
start or end a session, a command, a gain -- needs the token printed at start-up and
the operator holding control; an E-stop needs neither.
"""

from __future__ import annotations

import contextlib
import multiprocessing as mp
import os
import re
import threading
import time
from pathlib import Path
from typing import Any

import numpy as np

from exoleg.control.contract import vocabulary
from exoleg.control.hierarchy import WalkGains
from exoleg.entry import DEFAULT_BODY_MASS
from exoleg.errors import ParameterError
from exoleg.hmi.archive import Archive
from exoleg.io import write_json
from exoleg.runtime.control_api import ControlAPI, body_of, loopback, source_of
from exoleg.runtime.link import LoopLink
from exoleg.runtime.session import SIMULATED_BUS, check_options

STATIC = Path(__file__).parent / "static"
#: the longest session the HMI starts, s (a session may be ended at any time before)
MAX_DURATION = 3600.0
#: the names and texts of the modes, phases, events, faults and safety bits, from the
#: enumerations the compiled tick uses (the page keeps no table of its own)
VOCABULARY = vocabulary()


def _slug(text: str) -> str:
    return re.sub(r"[^A-Za-z0-9_-]+", "-", text).strip("-")[:40] or "child"


def _session_process(link: LoopLink, backend: str, interface: str | None, duration: float,
                     folder: str, leg_path: str | None, body_mass: float, arm: bool,
                     cpus: set[int] | None) -> None:
    """A session's own process (``exoleg hmi``): runs the loop until its duration, an
    E-stop fault, the operator's end, a signal, or a lost link (the server's heartbeat:
    :class:`~exoleg.runtime.link.LoopLink`) -- then nobody could stop it from the page.
    ``cpus``: the CPUs the server had before it kept off the loop's
    (:func:`keep_off_loop_cpu`)."""
    import exoleg
    from exoleg.runtime.session import run

    if cpus:
        with contextlib.suppress(AttributeError, OSError):
            os.sched_setaffinity(0, cpus)
    try:
        leg = exoleg.load_leg(leg_path) if leg_path else None
        run(backend, duration, folder, leg=leg, body_mass=body_mass, arm=arm,
            interface=interface, link=link)
    except BaseException as e:  # said on the Sessions page; the torque is off either way
        write_json(Path(folder) / "failed.json",
                    {"error": f"{type(e).__name__}: {e}", "time": time.time()})
        link.loop_ended()


def device_info(leg: Any) -> dict[str, Any]:
    """What the live page draws with: link lengths and D-H offsets (the same kinematics
    as :func:`exoleg.kinematics.forward_kinematics`), the range of motion, the FSR
    positions, each actuator's torque limits and torque-speed envelope (SI units)."""
    from exoleg.control.contract import SENSOR_POINTS
    from exoleg.device.actuator import envelope, paper_actuators
    from exoleg.device.sensors import SENSOR_X
    from exoleg.dynamics._generated import OFFSETS
    from exoleg.params import paper

    acts = paper_actuators()
    rom = paper.range_of_motion()
    out: dict[str, Any] = {
        "leg": leg.name, "lengths": [float(x) for x in leg.lengths], "offsets": list(OFFSETS),
        "rom_lower": rom.lower.tolist(), "rom_upper": rom.upper.tolist(),
        "sensors": list(SENSOR_POINTS),
        "sensor_x": [float(x) * float(leg.lengths[2]) for x in SENSOR_X], "actuators": []}
    for a in acts:
        par = a.record()
        w = np.linspace(0.0, 1.1 * a.no_load_factor * a.max_velocity, 60)
        out["actuators"].append({
            "joint": a.joint, "torque_limit": a.torque_limit,
            "continuous_torque": a.continuous_torque, "max_velocity": a.max_velocity,
            "envelope_speed": w.tolist(),
            "envelope_torque": [float(envelope(par, x)) for x in w]})
    return out


class HMI:
    """The server's state: the session (running or not), the child kept for the next
    session, the sessions folder."""

    def __init__(self, root: str | Path, backend: str = "sim", interface: str | None = None,
                 token: str | None = None, fixed: tuple[LoopLink, Path] | None = None,
                 leg: Any = None) -> None:
        import exoleg

        self.root = Path(root)
        self.root.mkdir(parents=True, exist_ok=True)
        self.archive = Archive(self.root)
        self.api = ControlAPI(token, folder=self.root)
        self.backend, self.interface = backend, interface
        self.fixed = fixed is not None
        self.lock = threading.RLock()
        self.child: dict[str, Any] | None = None  # the fit kept for the next session
        self.child_leg: Path | None = None
        self.proc: Any = None
        self.session: Path | None = None
        self.leg = leg if leg is not None else exoleg.paper_leg()
        self.info = device_info(self.leg)
        self.host = "127.0.0.1"  # where it listens (set by serve)
        self.cpus: set[int] | None = None  # the server's CPUs before keep_off_loop_cpu
        if fixed is not None:
            self.session = Path(fixed[1])
            self.api.attach(fixed[0], self.session)

    # ------------------------------------------------------------------ sessions
    def start(self, duration: float, source: str, arm: bool = False
              ) -> tuple[int, dict[str, Any]]:
        """Start a session (its own process) with the child kept, if any. ``arm``: arm as
        the loop starts -- only on the simulated device, whose child has no muscles of its
        own and folds within about a second while the device is disarmed."""
        with self.lock:
            try:
                check_options(self.backend, self.interface, arm)
            except ParameterError as e:  # arming at the start on a real device
                return 409, {"error": f"arm as the session starts: {e.problem}"}
            if self.fixed:
                return 409, {"error": "this HMI serves one session run by `exoleg run`; it "
                                      "cannot start another"}
            if self.proc is not None and self.proc.is_alive():
                return 409, {"error": f"session {self.session.name if self.session else ''}"
                                      " is running; end it first"}
            if not (np.isfinite(duration) and 1.0 <= duration <= MAX_DURATION):
                return 422, {"error": f"duration {duration:g} s is outside 1-"
                                      f"{MAX_DURATION:g} s"}
            if self.child is not None and not self.child["fits"]:
                return 409, {"error": f"the device does not fit {self.child['child']['name']}"
                                      f": {'; '.join(self.child['notes'])}"}
            stem = time.strftime("%Y%m%d-%H%M%S") + "-" + _slug(
                self.child["child"]["name"] if self.child else "paper-leg")
            name, n = stem, 1
            while (self.root / name).exists():  # never into a recorded session's folder
                n += 1
                name = f"{stem}-{n}"
            folder = self.root / name
            folder.mkdir()
            if self.child is not None:
                write_json(folder / "child.json", self.child)
                (folder / "leg.toml").write_bytes(Path(str(self.child_leg)).read_bytes())
            link = LoopLink.new()
            mass = float(self.child["child"]["mass"]) if self.child else DEFAULT_BODY_MASS
            self.proc = mp.get_context("spawn").Process(
                target=_session_process, name="exoleg-session", daemon=True,
                args=(link, self.backend, self.interface, duration, str(folder),
                      str(folder / "leg.toml") if self.child else None, mass, arm,
                      self.cpus))
            self.proc.start()
            self.session = folder
            self.api.attach(link, folder)
            self.api.record(source, f"start session {name} ({duration:g} s, "
                            f"{self.backend}{', armed at start' if arm else ''})", True)
            threading.Thread(target=self._watch, args=(self.proc, link, folder),
                             daemon=True).start()
            return 200, {"session": name}

    def _watch(self, proc: Any, link: LoopLink, folder: Path) -> None:
        """When the session's process ends: its last applied commands and how it ended
        go to its control.log, and the page sees no session."""
        proc.join()
        with self.lock:
            if self.api.link is not link:  # a new session started in between
                return
            self.api.poll_applied()
            self.api.detach()
            self.api.record("hmi", "session ended", True,
                            why=self.archive.summary(folder)["stopped_by"])

    def end(self, source: str) -> tuple[int, dict[str, Any]]:
        with self.lock:
            link = self.api.link
            if link is None:
                return 409, {"error": "no session is running"}
        link.web_end()
        self.api.record(source, "end session", True)
        return 200, {"ending": self.session.name if self.session else ""}

    def close(self) -> None:
        """Stop a running session (its process ends with the torque off)."""
        with self.lock:
            proc, link = self.proc, self.api.link
        if proc is not None and proc.is_alive():
            if link is not None:
                link.web_end()
            proc.join(timeout=5)
            if proc.is_alive():
                proc.terminate()
                proc.join(timeout=5)

    # ------------------------------------------------------------------ the child
    def fit(self, body: dict[str, Any], source: str) -> tuple[int, dict[str, Any]]:
        """Fit the device to the child described (age y, height cm, mass kg, optional
        measured dimensions cm) and keep the fit for the next session."""
        import warnings

        from exoleg.entry import CHILD_ENTRY, MEASURED
        from exoleg.sizing import Child
        from exoleg.sizing.report import fit_report

        def typed(k: str, v: Any, kind: str) -> float:
            lo, hi, unit = CHILD_ENTRY[kind]
            x = float(v)
            if not lo <= x <= hi:
                raise ParameterError("child", k, f"{v!r} is outside {lo:g}-{hi:g} {unit}")
            return x

        try:
            values: dict[str, Any] = {k: typed(k, body.get(k, "nan"), k)
                                      for k in ("age", "height", "mass")}
            for k in MEASURED:
                if body.get(k) not in (None, ""):
                    values[k] = typed(k, body[k], "measured") / 100
            gmfcs = str(body.get("gmfcs") or "0")
            if gmfcs not in ("0", "1", "2", "3", "4", "5"):
                raise ParameterError("child", "gmfcs", f"{gmfcs!r} is not a GMFCS level "
                                     "(allowed: 1-5, or 0 for typically developing)")
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                child = Child(age=values.pop("age"), sex=str(body.get("sex", "")),  # type: ignore[arg-type]
                              height=values.pop("height") / 100, mass=values.pop("mass"),
                              gmfcs=int(gmfcs) or None,
                              affected_side=str(body.get("side", "right")),  # type: ignore[arg-type]
                              name=str(body.get("name", "child"))[:60] or "child",
                              **values)  # Child checks sex and side and names what is allowed
            rep = fit_report(child)
        except (ParameterError, ValueError, TypeError) as e:
            self.api.record(source, "fit", False, str(e))
            return 422, {"error": str(e)}
        record = rep.record(leg_file_written=True)
        record["warnings"] = [str(w.message) for w in caught]
        folder = self.root / "children" / _slug(child.name)
        folder.mkdir(parents=True, exist_ok=True)
        write_json(folder / "fit.json", record)
        rep.save_leg(folder / "leg.toml")
        with self.lock:
            self.child, self.child_leg = record, folder / "leg.toml"
            if not self.fixed:  # the next session's leg
                self.leg = rep.leg
                self.info = device_info(rep.leg)
        self.api.record(source, f"fit {child.name}: {rep.verdict}", True)
        return 200, record

    def live(self) -> Path | None:
        """The folder of the session running now (None when none runs)."""
        return self.session if self.api.link is not None else None

    # ------------------------------------------------------------------ the web app
    def app(self) -> Any:
        from starlette.applications import Starlette
        from starlette.concurrency import run_in_threadpool
        from starlette.requests import Request
        from starlette.responses import FileResponse, JSONResponse, Response
        from starlette.routing import Mount, Route
        from starlette.staticfiles import StaticFiles

        api = self.api

        async def index(request: Request) -> Response:
            return FileResponse(STATIC / "index.html")

        async def info(request: Request) -> JSONResponse:
            with self.lock:
                return JSONResponse({
                    "device": self.info, "backend": self.backend, "fixed": self.fixed,
                    "simulated": self.interface == SIMULATED_BUS.get(self.backend),
                    "child": self.child, "session": self.session.name if self.session
                    else None, "max_duration": MAX_DURATION,
                    "children": self.archive.children(), "vocabulary": VOCABULARY,
                    "gains": [g for g in WalkGains.TUNABLE if g != "support"]})

        async def fit(request: Request) -> JSONResponse:
            refused = api.refusal(request, "fit")
            if refused:
                return refused
            body = await body_of(request)
            status, out = await run_in_threadpool(self.fit, body, source_of(request))
            return JSONResponse(out, status)

        async def session_start(request: Request) -> JSONResponse:
            refused = api.refusal(request, "start session")
            if refused:
                return refused
            body = await body_of(request)
            try:
                duration = float(body.get("duration", 60.0))
            except (TypeError, ValueError):
                duration = float("nan")
            status, out = self.start(duration, source_of(request),
                                     arm=body.get("arm") is True)
            if status != 200:
                api.record(source_of(request), "start session", False, out["error"])
            return JSONResponse(out, status)

        async def session_end(request: Request) -> JSONResponse:
            refused = api.refusal(request, "end session")
            if refused:
                return refused
            status, out = self.end(source_of(request))
            return JSONResponse(out, status)

        async def sessions(request: Request) -> JSONResponse:
            return JSONResponse(await run_in_threadpool(self.archive.sessions, self.live()))

        def recorded(request: Request) -> Path:
            folder = self.archive.folder_of(request.path_params["name"])
            if folder is None:
                raise LookupError(request.path_params["name"])
            return folder

        async def session_detail(request: Request) -> Response:
            try:
                folder = recorded(request)
            except LookupError as e:
                return JSONResponse({"error": f"no recorded session {e}"}, 404)
            return JSONResponse(await run_in_threadpool(self.archive.detail, folder,
                                                        self.live()))

        async def session_file(request: Request) -> Response:
            try:
                folder = recorded(request)
            except LookupError as e:
                return JSONResponse({"error": f"no recorded session {e}"}, 404)
            kind = request.path_params["kind"]
            try:
                if kind == "plot.png":
                    path = await run_in_threadpool(self.archive.plot, folder)
                    return FileResponse(path, media_type="image/png")
                if kind in ("session.csv", "session.parquet"):
                    fmt = kind.split(".")[1]
                    path = await run_in_threadpool(self.archive.export, folder, fmt)
                    return FileResponse(path, filename=f"{folder.name}.{fmt}")
            except (ParameterError, OSError) as e:
                return JSONResponse({"error": f"session {folder.name}: {e}"}, 409)
            return JSONResponse({"error": f"unknown file {kind!r} (allowed: plot.png, "
                                          "session.csv, session.parquet)"}, 404)

        @contextlib.asynccontextmanager
        async def lifespan(app: Any) -> Any:
            import asyncio

            task = asyncio.create_task(api.watch())
            yield
            task.cancel()

        routes = [Route("/", index), Route("/api/info", info),
                  Route("/api/fit", fit, methods=["POST"]),
                  Route("/api/session/start", session_start, methods=["POST"]),
                  Route("/api/session/end", session_end, methods=["POST"]),
                  Route("/api/sessions", sessions),
                  Route("/api/sessions/{name}", session_detail),
                  Route("/api/sessions/{name}/{kind}", session_file),
                  Mount("/api", routes=api.routes()),
                  Mount("/static", app=StaticFiles(directory=STATIC), name="static")]
        from starlette.middleware import Middleware
        from starlette.middleware.trustedhost import TrustedHostMiddleware

        # on loopback, only requests addressed to loopback names: a page elsewhere that
        # rebinds its own name to 127.0.0.1 cannot read the state
        hosts = (["127.0.0.1", "localhost", "[::1]", self.host] if loopback(self.host)
                 else ["*"])
        return Starlette(routes=routes, lifespan=lifespan,
                         middleware=[Middleware(TrustedHostMiddleware, allowed_hosts=hosts)])
