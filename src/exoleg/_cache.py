"""Keep numba's on-disk cache consistent with the package's sources.

numba keys a cached function on its own file only: a function that calls or inlines a
compiled function of another module (the walking loop calling the control tick, the
stepper inlining the generated kernels) keeps its stale machine code when only that
other module changes -- after an upgrade or an edit. On import, exoleg compares a stamp
of every source file's size and modification time with the one it left in its
``__pycache__``; when they differ, it removes every cached numba entry of the package,
so each function compiles afresh once. The stamp costs a stat per file (about 1 ms).
"""

from __future__ import annotations

import contextlib
import hashlib
from pathlib import Path

_ROOT = Path(__file__).resolve().parent
_STAMP = _ROOT / "__pycache__" / "exoleg-numba-sources.stamp"


def _sources_stamp() -> str:
    h = hashlib.sha1()
    for f in sorted(_ROOT.rglob("*.py")):
        st = f.stat()
        h.update(f"{f.relative_to(_ROOT)}:{st.st_size}:{st.st_mtime_ns}\n".encode())
    return h.hexdigest()


def guard() -> None:
    """Drop the package's numba cache when any source changed since it was written."""
    with contextlib.suppress(OSError):  # read-only installs: nothing to keep consistent
        stamp = _sources_stamp()
        if _STAMP.exists() and _STAMP.read_text() == stamp:
            return
        for f in _ROOT.rglob("__pycache__/*"):
            if f.suffix in (".nbi", ".nbc"):
                f.unlink()
        _STAMP.parent.mkdir(exist_ok=True)
        _STAMP.write_text(stamp)
