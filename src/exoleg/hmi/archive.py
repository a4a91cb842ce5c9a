"""The operator interface's archive: the recorded sessions and the fitted children in one
folder -- listed, summarised, plotted and exported (CSV, Parquet), each looked up only by
its own name inside the folder."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from exoleg.errors import ParameterError
from exoleg.runtime.figures import stop_in_words
from exoleg.runtime.session import RECORD_FILES


class Archive:
    """The sessions and children under ``root`` (each session a folder with its
    ``session.log``, ``run.json``, ``control.log``; children under ``children/``)."""

    def __init__(self, root: Path) -> None:
        self.root = root

    def folder_of(self, name: str) -> Path | None:
        """A recorded session's folder, only by its own name (nothing outside the root)."""
        p = self.root / name
        if "/" in name or name.startswith(".") or not self._recorded(p):
            return None
        return p

    @staticmethod
    def _recorded(p: Path) -> bool:
        return any((p / n).is_file() for n in RECORD_FILES)

    def summary(self, folder: Path, live: Path | None = None) -> dict[str, Any]:
        """One recorded session's line: child, start, duration, how it ended (``live``:
        the folder of the session running now)."""
        from exoleg.session_log import check_session, read_header

        damaged: list[str] = []

        def read(name: str) -> dict[str, Any]:
            """A record of the session's (JSON object); {} when absent, and a damaged
            one said in ``damaged``."""
            path = folder / name
            if not path.exists():
                return {}
            try:
                data = json.loads(path.read_text(encoding="utf-8"))
                if not isinstance(data, dict):
                    raise ValueError("not a JSON object")
                return data
            except (OSError, ValueError, UnicodeDecodeError, RecursionError) as e:
                damaged.append(f"{name} is damaged ({type(e).__name__}: {str(e)[:80]})")
                return {}

        run, child, failed = read("run.json"), read("child.json"), read("failed.json")
        running = folder == live and not run and not failed  # its summary: ended
        try:
            header, ticks = read_header(folder / "session.log")
            check_session(folder / "session.log", header)
        except ParameterError as e:
            header, ticks = {}, 0
            if (folder / "session.log").exists() or not failed:
                damaged.append(f"session.log {e.problem}")
        who = child.get("child", {}) if isinstance(child.get("child"), dict) else {}
        stopped = failed.get("error") or run.get("stopped_by")
        return {"name": folder.name,
                "child": str(who.get("name", f"({header.get('leg', '?')})")),
                "child_id": child.get("child_id"),
                "started": float(header.get("started", folder.stat().st_mtime)),
                "backend": str(header.get("backend", "?")),
                "duration_s": ticks * float(header.get("period", 1e-3)),
                "stopped_by": str(stopped) if stopped else
                ("running" if running else "ended without a summary (log kept)"),
                "stopped_in_words": stop_in_words(str(stopped)) if stopped else None,
                "damaged": damaged, "running": running}

    def sessions(self, live: Path | None = None) -> list[dict[str, Any]]:
        """Every recorded session's line, the newest first."""
        rows = []
        for p in self.root.iterdir():
            if not self._recorded(p):
                continue
            try:
                rows.append(self.summary(p, live))
            except (OSError, ValueError, TypeError) as e:  # listed, with why
                rows.append({"name": p.name, "child": "?", "child_id": None,
                             "started": 0.0, "backend": "?", "duration_s": 0.0,
                             "stopped_by": "?", "stopped_in_words": None,
                             "running": False,
                             "damaged": [f"cannot be read: {type(e).__name__}: {e}"]})
        return sorted(rows, key=lambda r: -float(r["started"]))

    def detail(self, folder: Path, live: Path | None = None) -> dict[str, Any]:
        """One recorded session: its line, its figures as a clinician reads them
        (:func:`~exoleg.hmi.history.kept_figures`; None while it runs), its log's
        summary, its control actions."""
        from exoleg.hmi.history import kept_figures
        from exoleg.runtime.session import summarize

        out = self.summary(folder, live)
        out["figures"] = None if out["running"] else kept_figures(folder)
        try:
            out["log"] = summarize(folder / "session.log")
        except ParameterError as e:
            out["log"] = {"error": str(e)}
        out["control"] = []
        try:
            lines = (folder / "control.log").read_text(encoding="utf-8").splitlines()
        except FileNotFoundError:
            lines = []
        except (OSError, UnicodeDecodeError) as e:
            out["damaged"].append(f"control.log cannot be read ({e})")
            lines = []
        bad = 0
        for x in lines:
            try:
                a = json.loads(x) if x.strip() else None
            except (ValueError, RecursionError):
                a = None
            if isinstance(a, dict) and {"time", "source", "command"} <= a.keys():
                out["control"].append(a)
            elif x.strip():
                bad += 1
        if bad:
            out["damaged"].append(f"control.log: {bad} damaged line(s) left out")
        return out

    def plot(self, folder: Path) -> Path:
        """The session's figure, made once per log state."""
        from exoleg.plots.figures import session_figure

        png = folder / "session.png"
        log = folder / "session.log"
        if not png.exists() or png.stat().st_mtime < log.stat().st_mtime:
            session_figure(log, png)
        return png

    def report(self, folder: Path) -> Path:
        """The session's report for the clinic's file
        (:func:`exoleg.plots.report.write_report`), kept beside its records; made again
        when the log is newer."""
        from exoleg.hmi.history import history_until
        from exoleg.plots.report import write_report

        out = folder / "report.pdf"
        log = folder / "session.log"
        if not out.exists() or out.stat().st_mtime < log.stat().st_mtime:
            write_report(folder, out, history=history_until(folder))
        return out

    def c3d(self, folder: Path) -> Path:
        """The session for a gait lab as C3D (:func:`exoleg.runtime.exports.write_c3d`;
        a session of more than 65,535 ticks: its first file)."""
        from exoleg.runtime.exports import session_export, write_c3d

        out = folder / "session.c3d"
        log = folder / "session.log"
        if not out.exists() or out.stat().st_mtime < log.stat().st_mtime:
            return write_c3d(session_export(folder), out)[0]
        return out

    def export(self, folder: Path, fmt: str) -> Path:
        """The session's log as CSV or Parquet (the same series as ``exoleg simulate``)."""
        from exoleg.io import write_csv_table, write_parquet_table
        from exoleg.runtime.session import to_table

        out = folder / f"session.{fmt}"
        log = folder / "session.log"
        if not out.exists() or out.stat().st_mtime < log.stat().st_mtime:
            (write_csv_table if fmt == "csv" else write_parquet_table)(to_table(log), out)
        return out
