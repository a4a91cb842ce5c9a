"""Keep numba's on-disk cache consistent with the package's sources.

numba keys a cached function on its own file only: a function that calls or inlines a
compiled function of another module (the walking loop calling the control tick, the
stepper inlining the generated kernels) keeps its stale machine code when only that
other module changes -- after an upgrade or an edit. On import, exoleg compares a stamp
of every source file's size and modification time with the one it left in its
``__pycache__``; when they differ, it removes every cached numba entry of the package,
so each function compiles afresh once. The stamp costs a stat per file (about 1 ms).

numba's cache is not safe across processes: saving an entry reads the index, picks a
data file's number and writes the index, then the data -- two processes compiling at
once (the validation's or a study's workers on a fresh cache) could each number their
own entry 1, leaving an index naming one function's machine code for another's, and
every later process crashed calling it (found in ``exoleg validate --identify``: a
segmentation fault in the gravity gufunc until the cache was removed). :func:`guard`
also puts each cache folder's saves under an exclusive lock and its loads under a
shared one (``fcntl.flock`` on ``.exoleg-numba.lock`` in the folder; without fcntl, as
numba is).
"""

from __future__ import annotations

import contextlib
import hashlib
import os
from collections.abc import Callable
from pathlib import Path
from typing import Any

_ROOT = Path(__file__).resolve().parent
_STAMP = _ROOT / "__pycache__" / "exoleg-numba-sources.stamp"


def _sources_stamp() -> str:
    h = hashlib.sha1()
    for f in sorted(_ROOT.rglob("*.py")):
        st = f.stat()
        h.update(f"{f.relative_to(_ROOT)}:{st.st_size}:{st.st_mtime_ns}\n".encode())
    return h.hexdigest()


#: the lock file each numba cache folder's readers and writers share
LOCK_NAME = ".exoleg-numba.lock"


def _locked(method: Callable[..., Any], exclusive: bool) -> Callable[..., Any]:
    import fcntl

    mode = fcntl.LOCK_EX if exclusive else fcntl.LOCK_SH

    def run(self: Any, *args: Any) -> Any:
        try:
            f = open(os.path.join(self._cache_path, LOCK_NAME), "a")  # noqa: SIM115
        except OSError:  # a read-only cache folder: nobody writes it
            return method(self, *args)
        with f:
            fcntl.flock(f, mode)
            return method(self, *args)  # closing the file releases the lock
    return run


def process_safe() -> None:
    """Put numba's cache saves under an exclusive lock and its loads under a shared one,
    per cache folder (once per process)."""
    try:
        import fcntl  # noqa: F401

        from numba.core import caching
    except ImportError:
        return
    cls: Any = caching.IndexDataCacheFile
    if getattr(cls, "_exoleg_locked", False):
        return
    cls.save = _locked(cls.save, exclusive=True)
    cls.load = _locked(cls.load, exclusive=False)
    cls._exoleg_locked = True


def _drop_entries(folder: Path) -> None:
    """Remove a cache folder's numba entries, under its exclusive lock where there is one
    (a process loading from it meanwhile loads whole entries or none)."""
    names = [f for f in folder.iterdir() if f.suffix in (".nbi", ".nbc")]
    if not names:
        return
    try:
        import fcntl

        lock = open(folder / LOCK_NAME, "a")  # noqa: SIM115
    except (ImportError, OSError):
        lock = None
    try:
        if lock is not None:
            fcntl.flock(lock, fcntl.LOCK_EX)
        for f in names:
            f.unlink(missing_ok=True)
    finally:
        if lock is not None:
            lock.close()


class _AfterCaching:
    """A meta path finder that makes numba's cache process safe once
    ``numba.core.caching`` is imported (importing numba itself here would cost a quarter
    of a second on every ``import exoleg``)."""

    name = "numba.core.caching"

    def find_spec(self, fullname: str, path: Any, target: Any = None) -> Any:
        if fullname != self.name:
            return None
        import importlib.machinery

        spec = importlib.machinery.PathFinder.find_spec(fullname, path)
        if spec is None or spec.loader is None:
            return spec
        loader = spec.loader
        run = loader.exec_module

        def exec_module(module: Any) -> None:
            run(module)
            process_safe()

        loader.exec_module = exec_module  # type: ignore[method-assign]
        return spec


#: the lock file under which one process at a time builds a cache folder's gufuncs
BUILD_LOCK_NAME = ".exoleg-gufunc.lock"


@contextlib.contextmanager
def building(folder: Path) -> Any:
    """Hold ``folder``'s gufunc build lock, exclusive, across processes. A gufunc's
    cache is two entries -- its kernel and the wrapper that calls it by a symbol whose
    tag counts the functions its process compiled before -- and numba saves each on its
    own: two processes building one gufunc at once can leave one's kernel beside the
    other's wrapper, which then calls a symbol nothing defines, and every later process
    crashes (numba issue #10128, open; found as a segmentation fault in the inverse
    dynamics' gufunc after a source change, the suite's workers and a study's building
    it at once). Under this lock a process builds, or loads, both from one process's
    build. Numba's own per-entry lock (:data:`LOCK_NAME`) is another file: this one is
    held around it. Without fcntl, or a folder this user cannot write, no lock."""
    try:
        import fcntl

        folder.mkdir(exist_ok=True)
        f = open(folder / BUILD_LOCK_NAME, "a")  # noqa: SIM115
    except (ImportError, OSError):
        yield
        return
    with f:
        fcntl.flock(f, fcntl.LOCK_EX)
        yield


def guard() -> None:
    """Drop the package's numba cache when any source changed since it was written;
    make numba's cache safe across processes (:func:`process_safe`, now or when numba
    loads its cache module)."""
    import sys

    if _AfterCaching.name in sys.modules:
        process_safe()
    elif not any(isinstance(f, _AfterCaching) for f in sys.meta_path):
        sys.meta_path.insert(0, _AfterCaching())
    with contextlib.suppress(OSError):  # read-only installs: nothing to keep consistent
        stamp = _sources_stamp()
        if _STAMP.exists() and _STAMP.read_text() == stamp:
            return
        for folder in _ROOT.rglob("__pycache__"):
            _drop_entries(folder)
        _STAMP.parent.mkdir(exist_ok=True)
        _STAMP.write_text(stamp)
