"""Imported by the server of the console's session processes (multiprocessing's
forkserver: :class:`exoleg.hmi.processes.SessionProcesses`), and by nothing else.

A session's process started afresh (``spawn``) imports the loop, sets up numba's compiler
target and loads every compiled function from numba's cache before its first tick (the
figures: :class:`~exoleg.hmi.processes.SessionProcesses`). This module does that once, in
the process every session is then forked from: a session
of two ticks on the simulated device with a child acting (the kernels of the device, the
child, the walking controller and the compiled tick), in a folder deleted after. The
forked session's process then builds its own device and starts ticking.

It leaves no thread behind (the run joins its tick's thread): a process is forked safely
only from a single thread (``tests/unit/test_session_process.py``).
"""

from __future__ import annotations

import os
import tempfile

import scipy.linalg  # noqa: F401  (a session with a console bounds its law: control.gears)

import exoleg.identify.device  # noqa: F401  (an identification's process runs it)
from exoleg.child.model import ChildModel
from exoleg.runtime.session import run


def _warm() -> None:
    with tempfile.TemporaryDirectory(prefix="exoleg-warm-") as d:
        run("sim", 0.002, os.path.join(d, "s"), realtime=False,
            child=ChildModel.typical("warm-up", 10.0, 1.38, 32.0))


try:
    _warm()
except Exception:
    # only the forked sessions' head start: the forkserver survives an import's
    # ImportError alone, and with it every session start. Whatever failed here, each
    # session's own run meets again and reports it (failed.json, on the Sessions page).
    pass
