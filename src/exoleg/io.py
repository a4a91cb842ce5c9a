"""Files in and out, safely: user files read with clear errors, outputs written whole or not at all.

* :func:`read_text` reads a file a user named (a leg file, a device file) and turns
  every way it can be wrong -- missing, a folder, unreadable, binary, not UTF-8,
  absurdly large -- into one :class:`~exoleg.errors.ParameterError` naming the file.
* :func:`atomic_path` writes one file through a temporary file in the same folder,
  renamed over the target only when the writing succeeded: an error or an interrupt
  leaves the previous file, or none, never a truncated one.
* :class:`OutputFolder` does the same for a set of files (a run's time series, summary
  and figures): they are written into a hidden staging folder inside the output
  folder and moved into place together at :meth:`OutputFolder.commit`, the summary
  last; interrupts are held off while they move. Files of the user's in the output
  folder that the run does not write are never touched.
"""

from __future__ import annotations

import contextlib
import os
import shutil
import signal
import tempfile
from collections.abc import Iterator
from pathlib import Path
from types import TracebackType
from typing import TYPE_CHECKING, Any

from exoleg.errors import ParameterError

if TYPE_CHECKING:
    import pyarrow as pa

#: Largest parameter file read, bytes: a leg or device file is a few kB.
MAX_PARAMETER_FILE = 1 << 20


def check_regular(path: str | Path, what: str = "file") -> None:
    """``path`` is a regular file (or a link to one), or a ParameterError naming what it is:
    a named pipe, a device or a socket would block a reader or never end (a folder, a
    missing or an unreadable file are left to the reader to name)."""
    import stat

    try:
        mode = Path(path).stat().st_mode
    except OSError:
        return
    if stat.S_ISDIR(mode) or stat.S_ISREG(mode):
        return
    kind = ("a named pipe" if stat.S_ISFIFO(mode) else "a socket" if stat.S_ISSOCK(mode)
            else "a device" if stat.S_ISCHR(mode) or stat.S_ISBLK(mode) else "a special file")
    raise ParameterError(str(path), "(file)", f"is {kind}, not a {what}: give a regular file")


def toml_string(s: str) -> str:
    """A TOML basic string holding ``s`` exactly: quotes, backslashes and every control
    character escaped (JSON's escapes are TOML's; DEL, which JSON leaves as it is, too)."""
    import json

    return json.dumps(s, ensure_ascii=False).replace(chr(0x7F), "\\u007F")


def read_text(path: str | Path, what: str = "file", limit: int = MAX_PARAMETER_FILE) -> str:
    """The text of a small UTF-8 file, or a ParameterError naming the file and the problem."""
    p = Path(path)
    where = str(p)
    check_regular(p, what)
    try:
        if p.is_dir():
            raise ParameterError(where, "(file)", f"is a folder; expected a {what}")
        size = p.stat().st_size
        if size > limit:
            raise ParameterError(where, "(file)", f"is {size:,} bytes; a {what} is at most "
                                                  f"{limit:,} bytes")
        data = p.read_bytes()
    except FileNotFoundError:
        raise ParameterError(where, "(file)", f"no such file (expected a {what})") from None
    except PermissionError:
        raise ParameterError(where, "(file)", "cannot be read: permission denied") from None
    except OSError as e:
        raise ParameterError(where, "(file)", f"cannot be read: {e.strerror or e}") from None
    if b"\x00" in data:
        raise ParameterError(where, "(file)", f"is a binary file; expected a {what} (UTF-8 text)")
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as e:
        raise ParameterError(where, "(file)", f"is not UTF-8 text (byte {e.start}); expected a "
                                              f"{what}") from None


def _writable_folder(folder: Path) -> Path:
    """``folder``, created if missing; a ParameterError when that cannot be."""
    where = str(folder)
    try:
        if folder.exists() and not folder.is_dir():
            raise ParameterError(where, "(output)", "exists and is not a folder; name a folder")
        folder.mkdir(parents=True, exist_ok=True)
    except FileExistsError:
        raise ParameterError(where, "(output)", "a parent of it is a file, not a folder") from None
    except PermissionError:
        raise ParameterError(where, "(output)", "cannot be created: permission denied") from None
    except OSError as e:
        raise ParameterError(where, "(output)", f"cannot be created: {e.strerror or e}") from None
    if not os.access(folder, os.W_OK | os.X_OK):
        raise ParameterError(where, "(output)", "is not writable: permission denied")
    return folder


@contextlib.contextmanager
def atomic_path(path: str | Path) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; on success it replaces ``path``."""
    target = Path(path)
    if target.is_dir():
        raise ParameterError(str(target), "(output)", "is a folder; name a file to write")
    folder = _writable_folder(target.parent if str(target.parent) else Path("."))
    fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".tmp", dir=folder)
    os.close(fd)
    try:
        yield Path(tmp)
        os.replace(tmp, target)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise


def write_json(path: str | Path, record: Any) -> Path:
    """``record`` as indented JSON at ``path``, written whole or not at all (a reader --
    the operator interface listing a session still running -- never sees half)."""
    import json

    with atomic_path(path) as tmp:
        tmp.write_text(json.dumps(record, indent=2))
    return Path(path)


def read_record(path: str | Path) -> dict[str, Any]:
    """A session's JSON record (``run.json``, ``child.json``, ``figures.json``) as
    :func:`write_json` wrote it: a JSON object, or {} when it is missing, unreadable or
    damaged (not JSON, not an object) -- what the record would have said is then not
    known, and every reader says so rather than fails."""
    import json

    try:
        record = json.loads(Path(path).read_text(encoding="utf-8"))
    except (OSError, ValueError, UnicodeDecodeError, RecursionError):
        return {}
    return record if isinstance(record, dict) else {}


def write_csv_table(table: pa.Table, path: str | Path) -> Path:
    """An Arrow table as CSV with an unquoted header line; each number the shortest
    decimal that reads back as the same float (nothing recorded is lost); written whole
    or not at all."""
    import pyarrow.csv as pcsv

    with atomic_path(path) as tmp, tmp.open("wb") as f:
        f.write((",".join(table.column_names) + "\n").encode())
        pcsv.write_csv(table, f, pcsv.WriteOptions(include_header=False))
    return Path(path)


def write_parquet_table(table: pa.Table, path: str | Path) -> Path:
    """An Arrow table as Parquet, written whole or not at all."""
    import pyarrow.parquet as pq

    with atomic_path(path) as tmp:
        pq.write_table(table, tmp)
    return Path(path)


@contextlib.contextmanager
def signals_held() -> Iterator[None]:
    """SIGINT and SIGTERM wait until the block is done (main thread only)."""
    import threading

    if threading.current_thread() is not threading.main_thread():
        yield
        return
    pending: list[int] = []

    def hold(signum: int, frame: object) -> None:
        pending.append(signum)

    old = {s: signal.signal(s, hold) for s in (signal.SIGINT, signal.SIGTERM)}
    try:
        yield
    finally:
        for s, h in old.items():
            signal.signal(s, h)
        for n in pending:
            signal.raise_signal(n)


#: the staging folders of the OutputFolders open in this process (a SIGTERM removes them:
#: :func:`remove_staging`)
_STAGING: set[Path] = set()


def remove_staging() -> None:
    """Remove every open OutputFolder's staging folder (a process ending on a signal)."""
    for p in list(_STAGING):
        shutil.rmtree(p, ignore_errors=True)
        _STAGING.discard(p)


#: The hidden record in an output folder of which file each exoleg command wrote there.
OUTPUTS = ".exoleg-outputs.json"


def _outputs(folder: Path) -> dict[str, str]:
    """The folder's record of its files' writers (file name -> command); {} when none or
    unreadable (then every file in it is taken for the user's)."""
    import json

    try:
        d = json.loads((folder / OUTPUTS).read_text())
    except (OSError, ValueError):
        return {}
    return {str(k): str(v) for k, v in d.items()} if isinstance(d, dict) else {}


def refuse_overwrite(folder: str | Path, owner: str, names: Any) -> None:
    """A ParameterError when a file of ``names`` is in ``folder`` already and ``owner``
    (the command, ``"exoleg identify"``) did not write it there: the user's own file, or
    another command's (:data:`OUTPUTS`). Nothing is written."""
    folder = Path(folder)
    record = _outputs(folder)
    for n in names:
        if (folder / n).exists() and record.get(n) != owner:
            by = (f"written by {record[n]}" if n in record
                  else "not recorded as exoleg's: yours, or an older exoleg's")
            raise ParameterError(str(folder), "(output)", f"{n} is there already ({by}): "
                                 f"{owner} does not write over it -- name another folder "
                                 "with --out")


class OutputFolder:
    """A run's output folder, written whole or not at all, never over another's files.

    ``stage(name)`` gives the path to write ``name`` to (in a hidden staging folder);
    ``commit(last=...)`` moves every staged file into the folder (``last`` after the
    others) with interrupts held off; leaving the ``with`` block without a commit (an
    error, Ctrl-C) removes the staging folder and leaves the folder as it was.

    ``owner`` (the command, ``"exoleg fit"``): the folder keeps a record of which command
    wrote each file (:data:`OUTPUTS`). A file already there that this command did not
    write -- the user's own, another command's -- is never written over: the commit is
    refused naming it (``will_write``: names checked at once, before any work). Files
    this command wrote last time and does not write now are removed (a re-fit leaves no
    previous child's file beside the new one).
    """

    def __init__(self, folder: str | Path, owner: str = "",
                 will_write: tuple[str, ...] = ()) -> None:
        self.folder = _writable_folder(Path(folder))
        self.owner = owner
        self._check(will_write)
        self._staging = Path(tempfile.mkdtemp(prefix=".exoleg-staging-", dir=self.folder))
        _STAGING.add(self._staging)
        self._names: list[str] = []

    def _check(self, names: Any) -> None:
        if self.owner:
            refuse_overwrite(self.folder, self.owner, names)

    @property
    def staging(self) -> Path:
        """The hidden staging folder (for a writer that names its own files; register
        each with :meth:`stage`)."""
        return self._staging

    def stage(self, name: str) -> Path:
        """Where to write the file ``name`` (a plain file name, no folders)."""
        if Path(name).name != name or name in ("", ".", ".."):
            raise ParameterError(str(self.folder), "(output)", f"bad output file name {name!r}")
        if name not in self._names:
            self._names.append(name)
        return self._staging / name

    def commit(self, last: str | None = None) -> list[Path]:
        """Move the staged files into the folder; returns their final paths."""
        order = [n for n in self._names if n != last] + ([last] if last in self._names else [])
        written = [n for n in order if (self._staging / n).exists()]
        self._check(written)
        record = _outputs(self.folder)
        stale = [n for n, by in record.items() if by == self.owner and n not in written]
        done = []
        with signals_held():
            for n in written:
                os.replace(self._staging / n, self.folder / n)
                done.append(self.folder / n)
            if self.owner:
                for n in stale:
                    with contextlib.suppress(OSError):
                        (self.folder / n).unlink()
                    record.pop(n, None)
                record.update({n: self.owner for n in written})
                self._record(record)
            self.discard()
        return done

    def _record(self, record: dict[str, str]) -> None:
        import json

        tmp = self._staging / OUTPUTS
        tmp.write_text(json.dumps(record, indent=1, sort_keys=True) + "\n")
        os.replace(tmp, self.folder / OUTPUTS)

    def discard(self) -> None:
        shutil.rmtree(self._staging, ignore_errors=True)
        _STAGING.discard(self._staging)

    def __enter__(self) -> OutputFolder:
        return self

    def __exit__(self, et: type[BaseException] | None, e: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.discard()
