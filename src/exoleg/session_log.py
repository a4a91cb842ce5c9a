"""The session log: every tick's record, surviving a crash.

Format: one header line ``EXOLEG-LOG 1 <json>\\n`` (the columns, the tick period, what
ran), then fixed-size records of float64 (one per tick, the columns in order). Records
are written with ``os.write`` -- straight to the kernel, which keeps them when the
process is killed (SIGKILL included) -- in batches of ``batch`` ticks: at most
``batch`` ticks are lost when the process dies (:data:`MAX_LOSS_TICKS` by default),
none on a normal or signalled stop, which flushes. A power cut can lose what the
kernel had not written to disk: :meth:`SessionLog.close` fsyncs, and every
``fsync_every``-th batch is fsynced by a thread of the log's own, never by the loop's (an
fsync on this VM's disk took 78.7 ms once, under a browser test's writes: a loop overrun
that took the torque off).

:func:`read_log` reads every complete record (a record cut by the crash is dropped and
reported) into named columns, the same series format as ``exoleg simulate``.
"""

from __future__ import annotations

import json
import os
import threading
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from exoleg.errors import ParameterError

MAGIC = b"EXOLEG-LOG 1 "
#: ticks that may be lost when the process is killed (the unwritten batch)
MAX_LOSS_TICKS = 20
F64 = NDArray[np.float64]


class SessionLog:
    """Append-only, crash-safe log of ``columns`` (names) per tick."""

    def __init__(self, path: str | Path, columns: list[str], meta: dict[str, Any],
                 batch: int = MAX_LOSS_TICKS, fsync_every: int = 50) -> None:
        self.path = Path(path)
        self.columns = list(columns)
        self.batch = int(batch)
        self.fsync_every = int(fsync_every)
        header = MAGIC + json.dumps({"columns": self.columns, **meta}).encode() + b"\n"
        try:
            self.fd = os.open(self.path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o644)
        except OSError as e:
            raise ParameterError(str(self.path), "(log)", f"cannot be written: "
                                 f"{e.strerror or e}") from None
        os.write(self.fd, header)
        self._buf = np.empty((self.batch, len(self.columns)))
        self._n = 0
        self._batches = 0
        self.records = 0
        #: an fsync that failed in the background (raised by the next flush)
        self.sync_error: OSError | None = None
        self._sync = threading.Event()
        self._closing = False
        self._syncer = threading.Thread(target=self._sync_loop, name="exoleg-log-fsync",
                                        daemon=True)
        self._syncer.start()

    def _sync_loop(self) -> None:
        while True:
            self._sync.wait()
            self._sync.clear()
            if self._closing:
                return
            try:
                os.fsync(self.fd)
            except OSError as e:  # the loop learns of it at its next flush
                self.sync_error = e

    def append(self, row: F64) -> None:
        """One tick's record (len(columns) values)."""
        self._buf[self._n] = row
        self._n += 1
        if self._n == self.batch:
            self.flush()

    def flush(self) -> None:
        if self.sync_error is not None:
            e, self.sync_error = self.sync_error, None
            raise e
        if self._n:
            os.write(self.fd, self._buf[: self._n].tobytes())
            self.records += self._n
            self._n = 0
            self._batches += 1
            if self._batches % self.fsync_every == 0:
                self._sync.set()  # the log's thread fsyncs; the loop goes on

    def close(self) -> None:
        if self.fd >= 0:
            self._closing = True
            self._sync.set()
            self._syncer.join(timeout=10)
            try:
                self.flush()
                os.fsync(self.fd)
            finally:
                os.close(self.fd)
                self.fd = -1


def _open(path: str | Path) -> tuple[Path, Any]:
    from exoleg.io import check_regular

    p = Path(path)
    if p.is_dir():
        p = p / "session.log"
    check_regular(p, "session log")
    try:
        return p, p.open("rb")
    except FileNotFoundError:
        raise ParameterError(str(p), "(log)", "no such session log") from None
    except OSError as e:
        raise ParameterError(str(p), "(log)", f"cannot be read: {e.strerror or e}") from None


def _header(p: Path, f: Any) -> tuple[dict[str, Any], list[str], int]:
    line = f.readline(1 << 20)
    if not line.startswith(MAGIC) or not line.endswith(b"\n"):
        raise ParameterError(str(p), "(log)", "is not an exoleg session log")
    try:
        header = json.loads(line[len(MAGIC):-1])
    except (ValueError, RecursionError):
        raise ParameterError(str(p), "(log)", "has a damaged header (not JSON)") from None
    why = header_problem(header)
    if why:
        raise ParameterError(str(p), "(log)", f"has a damaged header: {why}")
    return header, list(header["columns"]), len(line)


#: the columns every session's log has (what its summary reads)
SESSION_COLUMNS = ("t", "late", "mode", "safety_status", "events")


def check_session(path: str | Path, header: dict[str, Any]) -> None:
    """Refuses (ParameterError naming ``path``) a log whose header is not a session's:
    it lacks a column of :data:`SESSION_COLUMNS`."""
    missing = [c for c in SESSION_COLUMNS if c not in header["columns"]]
    if missing:
        raise ParameterError(str(path), "(log)", f"has a damaged header: no column "
                             f"{missing[0]!r} (a session log has "
                             f"{', '.join(SESSION_COLUMNS)})")


def check_records(path: str | Path, cols: dict[str, F64]) -> None:
    """Refuses (ParameterError naming ``path``, the column and the tick) a session log
    whose records do not hold what its header names: a time, a lateness, a mode, a safety
    status or an event word that is not a finite number (its records and its header
    disagree: a damaged log is not summarised as data)."""
    for c in SESSION_COLUMNS:
        bad = ~np.isfinite(cols[c])
        if bad.any():
            k = int(np.argmax(bad))
            raise ParameterError(str(path), c, f"tick {k} holds {float(cols[c][k])!r}: the "
                                 "log is damaged (its records do not hold what its header "
                                 "names)")


def header_problem(header: Any) -> str:
    """What is wrong with a log's header ('' when nothing): not an object; no columns, or
    columns that are not distinct names; a period, start or body mass that is not a
    plausible number."""
    if not isinstance(header, dict):
        return "not a JSON object"
    cols = header.get("columns")
    if not isinstance(cols, list) or not cols:
        return "lists no columns"
    if not all(isinstance(c, str) and c for c in cols) or len(set(cols)) != len(cols):
        return "its columns are not distinct names"
    for key, lo, hi in (("period", 1e-5, 1.0), ("started", 0.0, 1e11),
                        ("body_mass", 1.0, 200.0)):
        v = header.get(key, lo)
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not lo <= v <= hi:
            return f"its {key} {str(v)[:30]!r} is not a number within {lo:g}-{hi:g}"
    return ""


def read_header(path: str | Path) -> tuple[dict[str, Any], int]:
    """(header, whole ticks recorded so far) without reading the records: a log being
    written may be read."""
    p, f = _open(path)
    with f:
        header, cols, start = _header(p, f)
        size = os.fstat(f.fileno()).st_size
    return header, (size - start) // (8 * len(cols))


def read_log(path: str | Path, columns: Sequence[str] | None = None
             ) -> tuple[dict[str, Any], dict[str, F64], int]:
    """(header, columns (name -> (N,)), bytes of a cut final record dropped). ``columns``:
    only these (those the log has), each gathered from the file's pages as mapped --
    the export of a 30-minute session reads its 28 of 62 columns in 2.4 s, where
    reading the whole 0.9 GB and copying every column out took 5.7 s."""
    p, f = _open(path)
    with f:
        header, cols, start = _header(p, f)
        size = os.fstat(f.fileno()).st_size
    width = 8 * len(cols)
    n = (size - start) // width
    names = cols if columns is None else [c for c in columns if c in cols]
    if n == 0:
        return header, {c: np.zeros(0) for c in names}, size - start
    rows = np.memmap(p, dtype=np.float64, mode="r", offset=start, shape=(n, len(cols)))
    out = {c: np.array(rows[:, cols.index(c)]) for c in names}
    del rows  # (unmapped: the columns are copies)
    return header, out, size - start - n * width
