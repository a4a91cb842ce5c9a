"""The console's session processes are forked from a server of processes that has loaded
the loop once, once it is ready; started afresh before (exoleg.hmi.processes.
SessionProcesses, exoleg.hmi._warm).

References: POSIX fork -- a process forked while other threads run keeps only the
forking one, and whatever lock those held stays held: the process forked from must have
one thread; and the session itself -- forked from the loaded server it must log what a
process started afresh logs, to the bit (every column but the measured lateness, as
tests/test_realtime.py compares its two loops)."""

from __future__ import annotations

import multiprocessing as mp
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from exoleg.hmi.processes import SessionProcesses
from exoleg.hmi.testing import wait_until
from exoleg.session_log import read_log
from exoleg.tick import Mode

pytestmark = pytest.mark.skipif("forkserver" not in mp.get_all_start_methods(),
                                reason="this OS has no fork: sessions start afresh")

#: run in a fresh interpreter: what the server of processes holds after its preload
HELD = """
import threading
import exoleg.hmi._warm
from exoleg.runtime.ticker import run_ticks
print(threading.active_count(), len(run_ticks.signatures))
"""


def test_the_server_of_processes_holds_the_loop_loaded_and_one_thread() -> None:
    r = subprocess.run([sys.executable, "-c", HELD], capture_output=True, text=True,
                       timeout=120, check=False)
    assert r.returncode == 0, r.stderr
    threads, ticks = (int(x) for x in r.stdout.split())
    assert threads == 1  # the run joined its tick's thread: safe to fork from
    # its warm-up ran (a failure there is swallowed, to keep the server up): the compiled
    # tick -- the device, the child and the walking controller in one -- is loaded
    assert ticks == 1


def _session(folder: str) -> None:
    from exoleg.child.model import ChildModel
    from exoleg.runtime.session import run

    run("sim", 0.8, folder, arm=True, walk_after=0.1, realtime=False,
        child=ChildModel.typical("Ada", 8.0, 1.26, 25.0))


def _in(ctx: Any, folder: Path) -> dict[str, Any]:
    p = ctx.Process(target=_session, args=(str(folder),))
    p.start()
    p.join(timeout=120)
    assert p.exitcode == 0
    return read_log(folder / "session.log")[1]


def _forking(starts: SessionProcesses) -> Any:
    """``starts``' context once its server of processes is warmed and ready."""
    starts.warm()
    assert starts.warming is not None
    starts.warming.join(timeout=120)
    ctx = starts.context()
    assert ctx.get_start_method() == "forkserver"
    return ctx


def test_a_session_forked_from_it_logs_what_a_fresh_process_logs(tmp_path: Path) -> None:
    starts = SessionProcesses()
    # sessions start afresh until the server of processes is warmed and ready
    assert starts.context().get_start_method() == "spawn" and starts.warming is None
    forked = _in(_forking(starts), tmp_path / "forked")
    fresh = _in(mp.get_context("spawn"), tmp_path / "fresh")
    assert list(forked) == list(fresh)
    for name in forked:
        if name != "late":  # the one thing measured, not computed
            assert np.array_equal(forked[name], fresh[name], equal_nan=True), name
    assert len(forked["t"]) > 800 and np.any(forked["mode"] == Mode.WALKING)  # it walked


def _hold(name: str, folder: str, out: str) -> None:
    import os

    from exoleg.errors import ParameterError
    from exoleg.runtime.device_lock import hold_device

    os.environ["EXOLEG_LOCK_DIR"] = folder
    try:
        said = "held for it" if hold_device(name, "a session") is None else "held by it"
    except ParameterError as e:
        said = f"refused: {e.problem}"
    Path(out).write_text(said)


#: a process that does not descend from the test's: its parent ends, it is re-parented
ORPHAN = """
import os, sys, time
if os.fork():
    os._exit(0)
time.sleep(0.5)
sys.path.insert(0, sys.argv[1])
from test_session_process import _hold
_hold(sys.argv[2], sys.argv[3], sys.argv[4])
"""


def test_a_real_device_held_by_the_console_is_held_for_its_sessions(tmp_path: Path,
                                                                    monkeypatch: Any) -> None:
    # exoleg.runtime.device_lock: a session of `exoleg hmi` runs under the console's hold
    # on a real device, whether its process is the console's child (started afresh) or
    # its server of processes' child; any other process is refused
    from exoleg.runtime.device_lock import hold_device, let_go

    monkeypatch.setenv("EXOLEG_LOCK_DIR", str(tmp_path))
    name = "canopen:socketcan:exotest"
    fd = hold_device(name, "exoleg hmi")
    assert fd is not None
    try:
        for how, ctx in (("forked", _forking(SessionProcesses())),
                         ("fresh", mp.get_context("spawn"))):
            out = tmp_path / how
            p = ctx.Process(target=_hold, args=(name, str(tmp_path), str(out)))
            p.start()
            p.join(timeout=120)
            assert out.read_text() == "held for it", how
        out = tmp_path / "orphan"
        subprocess.run([sys.executable, "-c", ORPHAN, str(Path(__file__).parent), name,
                        str(tmp_path), str(out)], check=True, timeout=60)
        text = wait_until("the orphan's answer", lambda: out.exists() and out.read_text(), 60)
        assert text.startswith("refused: the device canopen:socketcan:exotest is held by "
                               "exoleg hmi"), text
    finally:
        let_go(fd)

