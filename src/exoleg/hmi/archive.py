"""The operator interface's archive: the recorded sessions and the fitted children in one
folder -- listed, summarised, plotted and exported (CSV, Parquet), each looked up only by
its own name inside the folder."""

from __future__ import annotations

import contextlib
import json
from pathlib import Path
from typing import Any

from exoleg.errors import ParameterError


class Archive:
    """The sessions and children under ``root`` (each session a folder with its
    ``session.log``, ``run.json``, ``control.log``; children under ``children/``)."""

    def __init__(self, root: Path) -> None:
        self.root = root

    def children(self) -> list[dict[str, Any]]:
        """The children fitted here before (their fit records), by name."""
        out = []
        for f in sorted((self.root / "children").glob("*/fit.json")):
            with contextlib.suppress(OSError, ValueError):
                out.append(json.loads(f.read_text())["child"])
        return out

    def folder_of(self, name: str) -> Path | None:
        """A recorded session's folder, only by its own name (nothing outside the root)."""
        p = self.root / name
        if "/" in name or name.startswith(".") or not self._recorded(p):
            return None
        return p

    @staticmethod
    def _recorded(p: Path) -> bool:
        return (p / "session.log").is_file() or (p / "failed.json").is_file()

    def summary(self, folder: Path, live: Path | None = None) -> dict[str, Any]:
        """One recorded session's line: child, start, duration, how it ended (``live``:
        the folder of the session running now)."""
        from exoleg.runtime.log import read_header

        def read(name: str) -> dict[str, Any]:
            try:
                return dict(json.loads((folder / name).read_text()))
            except (OSError, ValueError):
                return {}

        run, child, failed = read("run.json"), read("child.json"), read("failed.json")
        running = folder == live
        try:
            header, ticks = read_header(folder / "session.log")
        except ParameterError as e:
            header, ticks, failed = {}, 0, failed or {"error": str(e)}
        return {"name": folder.name,
                "child": child.get("child", {}).get("name", f"({header.get('leg', '?')})"),
                "started": float(header.get("started", folder.stat().st_mtime)),
                "backend": header.get("backend", "?"),
                "duration_s": ticks * float(header.get("period", 1e-3)),
                "stopped_by": failed.get("error") or run.get("stopped_by")
                or ("running" if running else "ended without a summary (log kept)"),
                "running": running}

    def sessions(self, live: Path | None = None) -> list[dict[str, Any]]:
        """Every recorded session's line, the newest first."""
        rows = [self.summary(p, live) for p in self.root.iterdir() if self._recorded(p)]
        return sorted(rows, key=lambda r: -float(r["started"]))

    def detail(self, folder: Path, live: Path | None = None) -> dict[str, Any]:
        """One recorded session: its line, its log's summary, its control actions."""
        from exoleg.runtime.session import summarize

        out = self.summary(folder, live)
        try:
            out["log"] = summarize(folder / "session.log")
        except ParameterError as e:
            out["log"] = {"error": str(e)}
        try:
            out["control"] = [json.loads(x) for x in
                              (folder / "control.log").read_text().splitlines() if x.strip()]
        except (OSError, ValueError):
            out["control"] = []
        return out

    def plot(self, folder: Path) -> Path:
        """The session's figure, made once per log state."""
        from exoleg.plots.figures import session_figure

        png = folder / "session.png"
        log = folder / "session.log"
        if not png.exists() or png.stat().st_mtime < log.stat().st_mtime:
            session_figure(log, png)
        return png

    def export(self, folder: Path, fmt: str) -> Path:
        """The session's log as CSV or Parquet (the same series as ``exoleg simulate``)."""
        from exoleg.io import write_csv_table, write_parquet_table
        from exoleg.runtime.session import to_table

        out = folder / f"session.{fmt}"
        log = folder / "session.log"
        if not out.exists() or out.stat().st_mtime < log.stat().st_mtime:
            (write_csv_table if fmt == "csv" else write_parquet_table)(to_table(log), out)
        return out
