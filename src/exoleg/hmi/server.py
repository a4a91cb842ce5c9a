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
import json
import threading
import time
from pathlib import Path
from typing import Any

import numpy as np

from exoleg.device import files as device_files
from exoleg.entry import DEFAULT_BODY_MASS
from exoleg.errors import ParameterError
from exoleg.hmi.archive import Archive
from exoleg.hmi.child_form import (
    actor_text,
    fit_of_form,
    write_actor,
)
from exoleg.hmi.history import expected_stride
from exoleg.hmi.processes import (
    IDENTIFIED,
    SessionProcesses,
    _identify_process,
    _session_process,
)
from exoleg.hmi.registry import FILE as RECORDS
from exoleg.hmi.registry import Registry
from exoleg.hmi.settings import apply_settings, kept_settings, settings_at_end
from exoleg.hmi.views import device_info, ended_record
from exoleg.io import write_json
from exoleg.runtime.control_api import (
    ControlAPI,
)
from exoleg.runtime.device_lock import device_name, hold_device, let_go
from exoleg.runtime.link import LoopLink
from exoleg.runtime.operator import REQUEST_OPERATOR
from exoleg.runtime.session import check_options, simulated

#: the longest session the HMI starts, s (a session may be ended at any time before)
MAX_DURATION = 3600.0
#: the longest note on a session, characters
NOTE_LIMIT = 2000
#: an identification's plan, s (exoleg.identify.plan.design_plan's range)
PLAN_RANGE = (10.0, 120.0)
#: how long a start waits for the last session's process to write its records once its
#: loop has ended, s: the page offers Start as the loop ends. Measured: a 35 s session's
#: figures take 0.03-0.23 s quiet; beside two CPU-bound processes and a busy suite a start
#: came while the process was still at them (refused then as a running session's)
RECORDS_WAIT_S = 30.0
#: how long the session's watcher waits for its ended process's exit code when another
#: thread reaped it (:meth:`HMI._watch`), s: that thread sets it in the next few
#: instructions it runs; a second covers the interpreter's switch interval (5 ms) on a
#: busy machine many times over
EXIT_CODE_WAIT_S = 1.0


class HMI:
    """The server's state: the session (running or not), the child kept for the next
    session, the sessions folder."""

    def __init__(self, root: str | Path, backend: str = "sim", interface: str | None = None,
                 token: str | None = None, fixed: tuple[LoopLink, Path] | None = None,
                 leg: Any = None, channel: str = "exoleg",
                 plan: tuple[float | None, float | None] = (None, None),
                 device_dir: str | Path | None = None) -> None:
        """``fixed``: the link and folder of the one session ``exoleg run --hmi`` runs,
        with ``plan``: its duration (s) and the child's body mass (kg). ``device_dir``: a
        folder of device files replacing the shipped ones, for every session,
        identification and fit (:mod:`exoleg.device.files`). A real device
        (``backend`` on a real ``interface`` and ``channel``) is held for as long as the
        interface serves (:func:`~exoleg.runtime.device_lock.hold_device`): a second
        console or run on it is refused."""
        import exoleg

        self.backend, self.interface, self.channel = backend, interface, channel
        self.device_dir = (None if device_dir is None
                           else str(device_files.check_folder(device_dir)))
        self.device = None
        if fixed is None and not simulated(backend, interface):
            self.device = hold_device(device_name(backend, interface, channel), "exoleg hmi")
        self.root = Path(root)
        self.root.mkdir(parents=True, exist_ok=True)
        self.archive = Archive(self.root)
        self.api = ControlAPI(token, folder=self.root)
        self.fixed = fixed is not None
        self.lock = threading.RLock()
        self.processes = SessionProcesses()
        # the children's records (not under `exoleg run --hmi`, which fits no child)
        self.registry = None if self.fixed else Registry(self.root / RECORDS,
                                                         legacy=self.root / "children")
        self.kept: dict[str, Any] | None = None  # the fit the next session runs on
        self.proc: Any = None
        self.watcher: threading.Thread | None = None  # the running session's (_watch)
        # the page's id of the start that began the running session, and its answer: a
        # start sent again with the same id (a browser resends a request whose reused
        # connection dropped before the answer) is answered again, not refused
        self.started: tuple[str, dict[str, Any]] | None = None
        self.session: Path | None = None
        self.ending: Path | None = None  # the session an End was sent to (it stops itself)
        self.leg = leg if leg is not None else exoleg.paper_leg()
        if self.registry is not None and leg is None:
            self._keep(self.registry.kept())
        self.info = device_info(self.leg, self.device_dir)
        self.host = "127.0.0.1"  # where it listens (set by serve)
        self.cpus: set[int] | None = None  # the server's CPUs before keep_off_loop_cpu
        if fixed is not None:
            self.session = Path(fixed[1])
            self.api.attach(fixed[0], self.session, *plan)

    # ------------------------------------------------------------------ sessions
    def start(self, duration: float, source: str, arm: bool = False,
              identify: bool = False, request: str | None = None
              ) -> tuple[int, dict[str, Any]]:
        """Start a session (its own process) with the child kept, if any. ``arm``: arm as
        the loop starts -- only on the simulated device, whose child has no muscles of its
        own and folds within about a second while the device is disarmed. ``identify``:
        the session plays identification's plan (``duration`` s of it; the operator starts
        it with Walk) and the identified leg is kept for the sessions after. ``request``:
        the page's id for this start; the same id again while its session runs gets the
        same answer (the start is not repeated, nor refused as another's). A session
        whose loop has ended -- the page shows it ended -- while its process still writes
        its records is waited for (up to :data:`RECORDS_WAIT_S`), not refused."""
        self._wait_for_records()
        with self.lock:
            running = self.proc is not None and self.proc.is_alive()
            if running and request is not None and self.started is not None \
                    and self.started[0] == request:
                return 200, self.started[1]
            try:
                check_options(self.backend, self.interface, arm)
            except ParameterError as e:  # arming at the start on a real device
                return 409, {"error": f"arm as the session starts: {e.problem}"}
            if self.fixed:
                return 409, {"error": "this HMI serves one session run by `exoleg run`; it "
                                      "cannot start another"}
            if running:
                name = self.session.name if self.session else ""
                if self._loop_ended():
                    return 409, {"error": f"session {name} has ended and is still writing "
                                          "its records; start again in a moment"}
                if self.session is not None and self.ending == self.session:
                    return 409, {"error": f"session {name} is ending (its controlled stop, "
                                          "then its records); start again once it has "
                                          "ended"}
                return 409, {"error": f"session {name} is running; end it first"}
            lo, hi, label = ((*PLAN_RANGE, "Plan (s)") if identify
                             else (1.0, MAX_DURATION, "Duration (s)"))
            if not (np.isfinite(duration) and lo <= duration <= hi):
                return 422, {"error": f"{label}: {duration:g} is outside {lo:g}-{hi:g} s"}
            kept = self.kept
            if kept is not None and not kept["record"]["fits"]:
                return 409, {"error": f"the device does not fit {kept['name']}: "
                                      f"{'; '.join(kept['record']['notes'])}"}
            stem = time.strftime("%Y%m%d-%H%M%S") + "-" + (kept["child_id"] if kept
                                                            else "paper-leg")
            stem += "-identify" if identify else ""
            name, n = stem, 1
            while (self.root / name).exists():  # never into a recorded session's folder
                n += 1
                name = f"{stem}-{n}"
            folder = self.root / name
            folder.mkdir()
            runs_on = self.runs_on()
            if kept is not None:
                write_json(folder / "child.json", {**kept["record"],
                                                   "child_id": kept["child_id"],
                                                   "fit_id": kept["id"]})
                (folder / "leg.toml").write_text(kept["leg"], encoding="utf-8")
                child_file = self._child_file(kept, folder, identify)
            else:
                child_file = None
            if self.registry is not None:
                self.registry.add_session(name, kept["child_id"] if kept else None,
                                          kept["id"] if kept else None, time.time(),
                                          REQUEST_OPERATOR.get())
            link = LoopLink.new()
            leg_path = str(folder / "leg.toml") if kept else None
            if identify:
                target: Any = _identify_process
                args: tuple[Any, ...] = (link, self.backend, self.interface, duration,
                                         str(folder), leg_path, arm, self.cpus, child_file,
                                         self.channel, self.device_dir)
            else:
                target = _session_process
                args = (link, self.backend, self.interface, duration, str(folder), leg_path,
                        runs_on["body_mass"], arm, self.cpus, child_file, self.channel,
                        self.device_dir, runs_on["expected_stride"])
            self.proc = self.processes.context().Process(
                target=target, name="exoleg-session", daemon=True, args=args)
            self.proc.start()
            self.session = folder
            self.api.attach(link, folder, duration, runs_on["body_mass"])
            what = (f"identification (a plan of {duration:g} s: Arm, then Walk starts it)"
                    if identify else f"{duration:g} s")
            self.api.record(source, f"start session {name} for {runs_on['text']} "
                            f"({what}, {self.backend}{', armed at start' if arm else ''})",
                            True)
            settings = None if identify else runs_on["settings"]
            self.watcher = threading.Thread(target=self._watch, daemon=True,
                                            args=(self.proc, link, folder, identify, settings))
            self.watcher.start()
            out = {"session": name, **runs_on, "identify": identify}
            self.started = None if request is None else (request, out)
            return 200, out

    def _loop_ended(self) -> bool:
        """Whether the attached session's loop has said it ended (its process may still
        be writing its records)."""
        link = self.api.link
        return link is not None and LoopLink.running(link.web_copy()) == "ended"

    def _wait_for_records(self) -> None:
        """A session whose loop has ended: its process and the watcher after it (the
        session's end in its control.log and the records) finish first -- outside the
        lock, which the watcher takes as it ends."""
        watcher = self.watcher
        if watcher is not None and watcher.is_alive() and self._loop_ended():
            watcher.join(timeout=RECORDS_WAIT_S)

    def _child_file(self, kept: dict[str, Any], folder: Path, wanted: bool = False
                    ) -> str | None:
        """The fitted child's ``child.toml`` in the session's folder
        (:func:`~exoleg.hmi.child_form.write_actor`) when the session's device is
        simulated; None on a real bus, where the child is real -- unless the child's
        model is ``wanted`` there too (identification holds their own torques at it)."""
        return write_actor(kept["record"], folder) if self._simulated() or wanted else None

    def runs_on(self) -> dict[str, Any]:
        """The child, leg and body mass the next session runs on, and that as text."""
        kept = self.kept
        if kept is None:
            return {"child": None, "child_id": None, "leg": self.leg.name,
                    "body_mass": DEFAULT_BODY_MASS, "settings": None, "expected_stride": None,
                    "text": f"no child fitted: the paper's leg {self.leg.name!r}, "
                            f"{DEFAULT_BODY_MASS:g} kg"}
        child = kept["record"]["child"]
        mass = float(child["mass"])
        gm = int(child.get("gmfcs") or 0)
        actor = ("" if not self._simulated() or gm > 4 else
                 f"; simulated as an actor ({actor_text(child, kept['record'].get('actor', {}))}"
                 ": child.toml in the session)")
        settings, said = kept_settings(self.registry, kept["child_id"])
        stride, stride_said = expected_stride(self.registry, self.root, kept["child_id"],
                                              self.device_dir)
        return {"child": kept["name"], "child_id": kept["child_id"], "leg": self.leg.name,
                "body_mass": mass, "settings": settings, "expected_stride": stride,
                "text": f"{kept['name']} ({kept['child_id']}, fit {kept['id']}): leg "
                f"{self.leg.name!r}, {mass:g} kg{actor}; {said}; {stride_said}"}

    def _simulated(self) -> bool:
        """Whether the sessions' device is simulated (the sim backend, or simulated nodes
        on a bus): only then is the child simulated too."""
        return simulated(self.backend, self.interface)

    def _keep(self, kept: dict[str, Any] | None) -> None:
        """The fit the next session runs on (its leg drawn by the pages)."""
        from exoleg import LegModel
        from exoleg.params.leg_file import parse_leg_text

        if kept is None:
            return
        links, g, name, meta = parse_leg_text(kept["leg"], f"fit {kept['id']}'s leg")
        with self.lock:
            self.kept = kept
            self.leg = LegModel(links, g=g, name=name, armature=meta.get("armature"))
            self.info = device_info(self.leg)

    def _watch(self, proc: Any, link: LoopLink, folder: Path, identify: bool = False,
               settings: dict[str, Any] | None = None) -> None:
        """The session's life from the server's side: the child's kept ``settings`` given
        to it as it starts (:func:`~exoleg.hmi.settings.apply_settings`); when its process
        ends, the settings it ended with kept in the records, its last applied commands
        and how it ended in its control.log, and the page sees no session; an
        identification's leg is kept for the sessions after (:meth:`keep_identified`). A
        process that ended while writing the shared block leaves it sealed
        (:meth:`~exoleg.runtime.link.LoopLink.web_seal`): nothing kept from it, said."""
        if settings is not None:
            try:
                apply_settings(self.api, link, settings)
            except RuntimeError as e:  # the block mid-write past the copy's retries
                self.api.record("session", "kept settings", False,
                                why=f"not given: {e}; the defaults stay")
        # the session ticking (or over: its process ended, or left its block mid-write,
        # which is sealed below): the next sessions' processes prepared beside it
        with contextlib.suppress(RuntimeError):
            while proc.is_alive() and LoopLink.running(link.web_copy()) == "starting":
                time.sleep(0.05)
        self.processes.warm()
        proc.join()
        # a process started meanwhile (the server of processes' first) polls every child
        # (multiprocessing's cleanup) and may have reaped this one first: its exit code is
        # then that thread's to set, a moment later (seen as None once in CI)
        deadline = time.monotonic() + EXIT_CODE_WAIT_S
        while proc.exitcode is None and time.monotonic() < deadline:
            time.sleep(0.005)
        torn = link.web_seal()
        ended_with = None if torn else settings_at_end(link)
        if ended_with is not None and self.registry is not None:
            self.registry.keep_settings(folder.name, ended_with)
        with self.lock:
            if identify:
                self.keep_identified(folder)
            if self.api.link is not link:  # a new session started in between
                return
            if torn:
                self.api.record("session", "session ended mid-write", False,
                                why=f"its process ended (exit code {proc.exitcode}) while "
                                    "writing its state for the console: the state shown "
                                    "last may mix two ticks, and the settings it ended "
                                    "with are not kept")
            self.api.poll_applied()
            stopped_by = self.archive.summary(folder)["stopped_by"]
            self.api.record("session", "session ended", True, why=stopped_by)
            self.api.detach(ended_record(folder.name, stopped_by, link))

    def keep_identified(self, folder: Path) -> None:
        """After an identification session in ``folder``: the identified leg, when there
        is one, becomes a fit of the child (their fit's record, with what identified it)
        kept for the next sessions; said in the session's control.log either way."""

        result = folder / IDENTIFIED / "identify.json"
        kept = self.kept
        if not result.exists():
            self.api.record("session", "identification", False,
                            why="no leg identified (the plan did not play to its end)")
            return
        summary = json.loads(result.read_text(encoding="utf-8"))
        leg_text = (folder / IDENTIFIED / "leg.toml").read_text(encoding="utf-8")
        text = ("held-out torque error " + ", ".join(
            f"{j} {v:.1f} %" for j, v in summary["held_out_pct"].items()))
        if self.registry is None or kept is None:
            self.api.record("session", "identification", True,
                            why=f"{text}; the paper's leg is kept (no child fitted)")
            return
        record = {**kept["record"], "identified": {"session": folder.name, **summary}}
        fit_id = self.registry.add_fit(kept["child_id"], record, leg_text)
        self.registry.keep(fit_id)
        self._keep(self.registry.fit(fit_id))
        self.api.record("session", "identification", True,
                        why=f"{text}; the identified leg (fit {fit_id}) is kept for the "
                            "next sessions")

    def end(self, source: str) -> tuple[int, dict[str, Any]]:
        with self.lock:
            link = self.api.link
            if link is None:
                return 409, {"error": "no session is running"}
        link.web_end()
        self.ending = self.session
        self.api.record(source, "end session", True)
        return 200, {"ending": self.session.name if self.session else ""}

    def note(self, text: Any, source: str) -> tuple[int, dict[str, Any]]:
        """The operator's note on the session running now, or the last one: kept in the
        records (replacing an earlier note) and in the session's control.log (every
        version, nothing written lost)."""
        if not isinstance(text, str):
            return 422, {"error": "note: expected text"}
        text = text.strip()
        if len(text) > NOTE_LIMIT:
            return 422, {"error": f"note: {len(text)} characters (at most {NOTE_LIMIT})"}
        with self.lock:
            session = self.session
            if session is None:
                return 409, {"error": "no session yet: start one, then write its note"}
            if self.registry is not None:
                self.registry.note(session.name, text)
        # the session's own log, ended or not (an ended one's actions go elsewhere)
        self.api.record(source, "note", True, why=text, log=session / "control.log")
        return 200, {"session": session.name, "note": text}

    def close(self) -> None:
        """Stop a running session (its process ends with the torque off), then let go of
        the device."""
        with self.lock:
            proc, link = self.proc, self.api.link
        if proc is not None and proc.is_alive():
            if link is not None:
                link.web_end()
            proc.join(timeout=5)
            if proc.is_alive():
                proc.terminate()
                proc.join(timeout=5)
        let_go(self.device)
        self.device = None

    # ------------------------------------------------------------------ the child
    def fit(self, body: dict[str, Any], source: str) -> tuple[int, dict[str, Any]]:
        """Fit the device to the child described (age y, height cm, mass kg, optional
        measured dimensions cm) and keep the fit for the next session."""
        if self.registry is None:
            return 409, {"error": "this interface serves the one session run by `exoleg "
                                  "run`: fit a child with `exoleg hmi` or `exoleg fit`"}
        cid = str(body.get("child_id") or "")
        if cid and not self.registry.exists(cid):
            return 422, {"error": f"no child {cid[:12]!r} in the records (choose one from "
                                  "the list, or leave it empty for a new child)"}
        try:
            child, rep, actor, warned = fit_of_form(body, self.device_dir)
        except (ParameterError, ValueError, TypeError) as e:
            self.api.record(source, "fit", False, str(e))
            return 422, {"error": str(e)}
        record = rep.record(leg_file_written=True)
        record["actor"] = actor
        record["actor_text"] = actor_text(record["child"], actor)
        record["warnings"] = warned
        reg = self.registry
        assert reg is not None  # refused above without one
        if cid:
            reg.rename(cid, child.name)
        else:
            cid = reg.add_child(child.name)
        fit_id = reg.add_fit(cid, record, rep.leg_text())
        reg.keep(fit_id)
        self._keep(reg.fit(fit_id))
        self.api.record(source, f"fit {child.name} ({cid}, fit {fit_id}): {rep.verdict}",
                        True)
        return 200, {**record, "child_id": cid, "fit_id": fit_id}

    def keep_child(self, child_id: str, source: str) -> tuple[int, dict[str, Any]]:
        """Keep child ``child_id``'s latest fit (their identified leg, when one was
        identified after the fit) for the next session: the child picked again, no
        re-fit."""
        reg = self.registry
        if reg is None:
            return 409, {"error": "this interface serves the one session run by `exoleg "
                                  "run`: it keeps no child"}
        fit_id = reg.latest_fit(child_id) if reg.exists(child_id) else None
        if fit_id is None:
            why = f"no child {child_id[:12]!r} with a fit in the records"
            self.api.record(source, "keep child", False, why)
            return 404, {"error": why}
        reg.keep(fit_id)
        self._keep(reg.fit(fit_id))
        runs_on = self.runs_on()
        self.api.record(source, f"keep child {child_id} (fit {fit_id})", True,
                        why=runs_on["text"])
        return 200, {**runs_on, "fit_id": fit_id}

    def sessions(self) -> list[dict[str, Any]]:
        """Every recorded session's line (:meth:`Archive.sessions`) with who started it
        and their note, from the records."""
        rows = self.archive.sessions(self.live())
        if self.registry is not None:
            for r in rows:
                rec = self.registry.session(r["name"]) or {}
                r["operator"], r["note"] = rec.get("operator"), rec.get("note")
        return rows

    def live(self) -> Path | None:
        """The folder of the session running now (None when none runs)."""
        return self.session if self.api.link is not None else None
