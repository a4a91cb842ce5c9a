"""numba's on-disk cache across processes (exoleg._cache.process_safe).

Reference: the cache's own contract -- an entry saved under a key loads back as what
was saved. Two processes saving entries into one cache folder at once (a validation's
or a study's workers compiling on a fresh cache) raced numba's read-number-write of its
index: an index naming one function's machine code for another's, and a segmentation
fault in every later process that loaded it."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

SAVER = r"""
import sys
import exoleg  # installs the lock on numba's cache
from numba.core.caching import IndexDataCacheFile
folder, who, n = sys.argv[1], sys.argv[2], int(sys.argv[3])
f = IndexDataCacheFile(folder, "f", "stamp")
for i in range(n):
    f.save((who, i), f"{who}-{i}".encode() * 50)
"""


def test_two_processes_saving_at_once_keep_every_entry(tmp_path: Path) -> None:
    # measured without the lock (exoleg._cache.process_safe not installed), four runs:
    # of 2 x 400 entries 228-410 lost or naming another's data; with it, none
    n = 400
    procs = [subprocess.Popen([sys.executable, "-c", SAVER, str(tmp_path), who, str(n)])
             for who in ("a", "b")]
    assert all(p.wait(timeout=120) == 0 for p in procs)
    from numba.core.caching import IndexDataCacheFile

    import exoleg  # noqa: F401

    f = IndexDataCacheFile(str(tmp_path), "f", "stamp")
    wrong = [(who, i) for who in ("a", "b") for i in range(n)
             if f.load((who, i)) != f"{who}-{i}".encode() * 50]
    assert wrong == []


def test_a_save_waits_for_the_lock(tmp_path: Path) -> None:
    import fcntl
    import time

    from exoleg._cache import LOCK_NAME

    with open(tmp_path / LOCK_NAME, "a") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        p = subprocess.Popen([sys.executable, "-c", SAVER, str(tmp_path), "a", "1"])
        time.sleep(1.5)
        assert p.poll() is None  # blocked on the lock
        assert not (tmp_path / "f.nbi").exists()
    assert p.wait(timeout=60) == 0
    assert (tmp_path / "f.nbi").exists()


def test_a_gufunc_is_built_by_one_process_at_a_time() -> None:
    # numba issue #10128 (open): a gufunc's kernel and its wrapper, cached by two
    # processes building it at once, mismatch -- the wrapper calls a kernel's symbol
    # nothing defines -- and every later process crashes calling it. Measured before
    # the build lock: after a source change, `pytest -n 2 tests/test_design.py` crashed
    # (a segmentation fault in the inverse dynamics' gufunc) in 4 of 5 runs, and the
    # cache stayed broken for every later run; with it, none in 5 runs (and 2 of
    # test_transparency + test_design + test_bad_inputs). Here: a process building a
    # gufunc waits while another holds the folder's build lock.
    import fcntl
    import time

    from exoleg._cache import BUILD_LOCK_NAME
    from exoleg.dynamics.kernels import _CACHE_FOLDER

    code = ("import time; from exoleg.dynamics import kernels; "
            "kernels.gufunc('potential_energy'); print(time.time())")
    with open(_CACHE_FOLDER / BUILD_LOCK_NAME, "a") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        p = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, text=True)
        time.sleep(2.0)  # (unlocked, it is built in about 0.6 s)
        released = time.time()
    out, _ = p.communicate(timeout=120)
    assert p.returncode == 0 and float(out) >= released  # built once the lock was free
