"""The children fitted at this device and the sessions they walked, as records in an
embedded SQLite database (``records.sqlite`` in the sessions folder).

A child is a pseudonymous id (``C`` and 8 hex digits, drawn at random) with a name that
is data, never a path: two children whose names differ only in punctuation or script are
two records. Each fit (the fit record and the leg file it made) belongs to one child;
each session started from the operator interface is linked to the child and the fit it
ran on; the fit kept for the next session survives a restart of the server.

The schema carries its version (``PRAGMA user_version``); :data:`MIGRATIONS` brings an
older database up to :data:`SCHEMA_VERSION` in one transaction per step, and a database
from a newer exoleg is refused, not rewritten. Children fitted before the database
(``children/<name>/fit.json`` and ``leg.toml``) are imported once, the first time the
database is made; a damaged one is reported (:attr:`Registry.damaged`) and left where it
is. A file that is not such a database is refused with its name -- never replaced.
"""

from __future__ import annotations

import json
import secrets
import sqlite3
import threading
import time
from pathlib import Path
from typing import Any

from exoleg.errors import ParameterError

#: the schema this exoleg writes
SCHEMA_VERSION = 3
#: the steps from each version to the next (version -> the SQL that makes it)
MIGRATIONS: dict[int, str] = {
    1: """
    CREATE TABLE children (
        id TEXT PRIMARY KEY CHECK (id GLOB 'C[0-9a-f][0-9a-f][0-9a-f][0-9a-f][0-9a-f]'
                                   || '[0-9a-f][0-9a-f][0-9a-f]'),
        name TEXT NOT NULL,
        created REAL NOT NULL);
    CREATE TABLE fits (
        id INTEGER PRIMARY KEY AUTOINCREMENT,
        child_id TEXT NOT NULL REFERENCES children(id),
        time REAL NOT NULL,
        record TEXT NOT NULL,   -- the fit record (JSON, exoleg.design.report)
        leg TEXT NOT NULL);     -- the leg file it made (TOML)
    CREATE TABLE sessions (
        name TEXT PRIMARY KEY,  -- the session's folder in the sessions folder
        child_id TEXT REFERENCES children(id),
        fit_id INTEGER REFERENCES fits(id),
        started REAL NOT NULL);
    CREATE TABLE kept (         -- the fit the next session runs on
        slot INTEGER PRIMARY KEY CHECK (slot = 0),
        fit_id INTEGER NOT NULL REFERENCES fits(id));
    """,
    2: """
    ALTER TABLE sessions ADD COLUMN operator TEXT;  -- who started it (their name)
    ALTER TABLE sessions ADD COLUMN note TEXT;      -- the operator's note on it
    """,
    3: """
    -- the support mode, gains and assist-as-needed bounds in force when it ended (JSON,
    -- exoleg.hmi.settings): the child's next session starts with them
    ALTER TABLE sessions ADD COLUMN settings TEXT;
    """,
}
FILE = "records.sqlite"


def new_child_id() -> str:
    return "C" + secrets.token_hex(4)


class Registry:
    """The records database at ``path`` (made, or brought up to date, on opening).
    Thread-safe: one connection, one lock."""

    def __init__(self, path: str | Path, legacy: str | Path | None = None) -> None:
        self.path = Path(path)
        self.lock = threading.RLock()
        self.damaged: list[str] = []  # legacy records that could not be imported, and why
        fresh = not self.path.exists()
        if self.path.is_dir():
            raise ParameterError("records", str(self.path), "is a folder, not a database")
        try:
            self.db = sqlite3.connect(self.path, check_same_thread=False,
                                      isolation_level=None)
            self.db.execute("PRAGMA foreign_keys = ON")
            self.db.execute("PRAGMA synchronous = FULL")
            version = int(self.db.execute("PRAGMA user_version").fetchone()[0])
        except sqlite3.DatabaseError as e:
            raise ParameterError("records", str(self.path), f"not an exoleg records "
                                 f"database ({e}); move it aside to start new records"
                                 ) from None
        if version > SCHEMA_VERSION:
            raise ParameterError("records", str(self.path), f"written by a newer exoleg "
                                 f"(schema {version}; this one reads up to "
                                 f"{SCHEMA_VERSION}): nothing was changed")
        if version == 0 and not fresh and self._tables():
            raise ParameterError("records", str(self.path), "a SQLite database that is "
                                 "not exoleg's (no schema version); move it aside")
        for v in range(version + 1, SCHEMA_VERSION + 1):
            self._migrate(v)
        if fresh and legacy is not None:
            self._import_legacy(Path(legacy))

    def _tables(self) -> list[str]:
        return [r[0] for r in self.db.execute(
            "SELECT name FROM sqlite_master WHERE type = 'table'")]

    def _migrate(self, version: int) -> None:
        with self.lock:
            self.db.execute("BEGIN IMMEDIATE")
            try:
                for statement in MIGRATIONS[version].split(";"):
                    if statement.strip():
                        self.db.execute(statement)
                self.db.execute(f"PRAGMA user_version = {version:d}")
                self.db.execute("COMMIT")
            except BaseException:
                self.db.execute("ROLLBACK")
                raise

    def _import_legacy(self, folder: Path) -> None:
        """Children fitted before the database: ``folder/<name>/fit.json`` + leg.toml."""
        for fit in sorted(folder.glob("*/fit.json")):
            try:
                record = json.loads(fit.read_text(encoding="utf-8"))
                leg = (fit.parent / "leg.toml").read_text(encoding="utf-8")
                name = str(record["child"]["name"])
            except (OSError, ValueError, KeyError, TypeError) as e:
                self.damaged.append(f"{fit}: not imported ({type(e).__name__}: {e})")
                continue
            cid = self.add_child(name, created=fit.stat().st_mtime)
            self.add_fit(cid, record, leg, when=fit.stat().st_mtime)

    def close(self) -> None:
        with self.lock:
            self.db.close()

    # ------------------------------------------------------------------ writing
    def add_child(self, name: str, created: float | None = None) -> str:
        """A new child record; returns its pseudonymous id."""
        with self.lock:
            while True:
                cid = new_child_id()
                try:
                    self.db.execute("INSERT INTO children VALUES (?, ?, ?)",
                                    (cid, name, time.time() if created is None else created))
                    return cid
                except sqlite3.IntegrityError:  # the same 32 random bits drawn twice
                    continue

    def add_fit(self, child_id: str, record: dict[str, Any], leg: str,
                when: float | None = None) -> int:
        """A fit of child ``child_id`` (its record and leg file); returns its id."""
        with self.lock:
            cur = self.db.execute(
                "INSERT INTO fits (child_id, time, record, leg) VALUES (?, ?, ?, ?)",
                (child_id, time.time() if when is None else when, json.dumps(record), leg))
            return int(cur.lastrowid or 0)

    def rename(self, child_id: str, name: str) -> None:
        with self.lock:
            self.db.execute("UPDATE children SET name = ? WHERE id = ?", (name, child_id))

    def keep(self, fit_id: int) -> None:
        """The fit the next session runs on (kept across restarts)."""
        with self.lock:
            self.db.execute("INSERT OR REPLACE INTO kept VALUES (0, ?)", (fit_id,))

    def add_session(self, name: str, child_id: str | None, fit_id: int | None,
                    started: float, operator: str | None = None) -> None:
        with self.lock:
            self.db.execute("INSERT INTO sessions (name, child_id, fit_id, started, "
                            "operator) VALUES (?, ?, ?, ?, ?)",
                            (name, child_id, fit_id, started, operator))

    def note(self, name: str, text: str) -> None:
        """The operator's note on session ``name`` (replacing an earlier one)."""
        with self.lock:
            self.db.execute("UPDATE sessions SET note = ? WHERE name = ?", (text, name))

    def keep_settings(self, name: str, settings: dict[str, Any]) -> None:
        """The settings session ``name`` ended with (:mod:`exoleg.hmi.settings`)."""
        with self.lock:
            self.db.execute("UPDATE sessions SET settings = ? WHERE name = ?",
                            (json.dumps(settings), name))

    # ------------------------------------------------------------------ reading
    def latest_fit(self, child_id: str) -> int | None:
        """The id of child ``child_id``'s latest fit (an identified leg is one), or None."""
        with self.lock:
            row = self.db.execute("SELECT id FROM fits WHERE child_id = ? ORDER BY time "
                                  "DESC, id DESC LIMIT 1", (child_id,)).fetchone()
        return None if row is None else int(row[0])

    def kept_settings(self, child_id: str) -> dict[str, Any] | None:
        """The settings child ``child_id``'s latest session with any ended with, and that
        session's ``session`` (its name) and ``started``; None before any."""
        with self.lock:
            row = self.db.execute(
                "SELECT name, started, settings FROM sessions WHERE child_id = ? AND "
                "settings IS NOT NULL ORDER BY started DESC, name DESC LIMIT 1",
                (child_id,)).fetchone()
        return None if row is None else {**json.loads(row[2]), "session": row[0],
                                         "started": row[1]}

    def exists(self, child_id: str) -> bool:
        with self.lock:
            return self.db.execute("SELECT 1 FROM children WHERE id = ?",
                                   (child_id,)).fetchone() is not None

    def fit(self, fit_id: int) -> dict[str, Any]:
        """A fit: ``id``, ``child_id``, ``name`` (the child's), ``time``, ``record``,
        ``leg`` (the leg file's text)."""
        with self.lock:
            row = self.db.execute(
                "SELECT fits.id, child_id, name, time, record, leg FROM fits JOIN children "
                "ON children.id = child_id WHERE fits.id = ?", (fit_id,)).fetchone()
        if row is None:
            raise LookupError(f"no fit {fit_id}")
        return {"id": row[0], "child_id": row[1], "name": row[2], "time": row[3],
                "record": json.loads(row[4]), "leg": row[5]}

    def kept(self) -> dict[str, Any] | None:
        """The fit kept for the next session (:meth:`fit`), or None."""
        with self.lock:
            row = self.db.execute("SELECT fit_id FROM kept WHERE slot = 0").fetchone()
        return None if row is None else self.fit(int(row[0]))

    def children(self) -> list[dict[str, Any]]:
        """Every child: ``id``, ``name``, the latest fit's child record (``child``) and
        actor settings (``actor``, empty for a fit made before them), ``fits`` and
        ``sessions`` counted; by name, then id."""
        with self.lock:
            rows = self.db.execute(
                "SELECT c.id, c.name, (SELECT record FROM fits WHERE child_id = c.id "
                "ORDER BY time DESC, id DESC LIMIT 1), "
                "(SELECT count(*) FROM fits WHERE child_id = c.id), "
                "(SELECT count(*) FROM sessions WHERE child_id = c.id) "
                "FROM children c ORDER BY c.name, c.id").fetchall()
        out = []
        for cid, name, record, fits, sessions in rows:
            rec = json.loads(record) if record else {}
            out.append({"id": cid, "name": name, "child": rec.get("child", {}),
                        "actor": rec.get("actor", {}), "fits": fits, "sessions": sessions})
        return out

    def sessions_of(self, child_id: str) -> list[dict[str, Any]]:
        """A child's sessions, oldest first: ``name`` (its folder), ``started`` (s since
        the epoch), ``fit_id``, ``operator``, ``note`` and the ``settings`` it ended with
        (None: not the walking controller, or ended before this was kept)."""
        with self.lock:
            rows = self.db.execute(
                "SELECT name, started, fit_id, operator, note, settings FROM sessions "
                "WHERE child_id = ? ORDER BY started, name", (child_id,)).fetchall()
        return [{"name": n, "started": t, "fit_id": f, "operator": o, "note": x,
                 "settings": None if k is None else json.loads(k)}
                for n, t, f, o, x, k in rows]

    def session(self, name: str) -> dict[str, Any] | None:
        """The child and fit a session ran on, who started it and their note (None when
        none is recorded)."""
        with self.lock:
            row = self.db.execute(
                "SELECT s.child_id, c.name, s.fit_id, s.operator, s.note FROM sessions s "
                "LEFT JOIN children c ON c.id = s.child_id WHERE s.name = ?",
                (name,)).fetchone()
        return None if row is None else {"child_id": row[0], "name": row[1],
                                         "fit_id": row[2], "operator": row[3],
                                         "note": row[4]}
