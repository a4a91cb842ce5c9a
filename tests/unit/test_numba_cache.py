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
