"""One device, one process: a real device -- a CAN channel, an EtherCAT network interface
-- is held by one exoleg process at a time, across ``exoleg hmi``, ``exoleg run`` and
``exoleg identify``. A second one is refused before it touches the bus, naming who holds
it. Simulated devices (the sim backend, simulated nodes on a virtual bus or segment) are
each their own and run side by side.

The hold is an exclusive ``flock`` on a file named after the device in the system's lock
folder (``/run/lock``, else the temporary folder; :data:`LOCK_DIR_ENV` names another), so
it is machine-wide and released by the kernel however the holder ends (a crash, a kill).
The file says who holds it: process, command, since when. The processes ``exoleg hmi``
starts for its sessions run under its hold (the console they descend from holds the
device for them: its child, or the child of its server of processes,
:class:`exoleg.hmi.processes.SessionProcesses`).
"""

from __future__ import annotations

import contextlib
import fcntl
import json
import os
import re
import sys
import tempfile
import time
from pathlib import Path

from exoleg.errors import ParameterError

#: the environment variable that names the folder of the devices' lock files
LOCK_DIR_ENV = "EXOLEG_LOCK_DIR"


def lock_dir() -> Path:
    """Where the devices' lock files are: :data:`LOCK_DIR_ENV`, else ``/run/lock`` when
    this user may write there, else the temporary folder."""
    named = os.environ.get(LOCK_DIR_ENV)
    if named:
        return Path(named)
    run = Path("/run/lock")
    return run if run.is_dir() and os.access(run, os.W_OK) else Path(tempfile.gettempdir())


def this_command() -> str:
    """What this process is, as a refused one reads it: ``exoleg hmi``, ``exoleg run``...
    (``a Python program`` when not the command line)."""
    argv = sys.argv
    if argv and Path(argv[0]).name == "exoleg" and len(argv) > 1:
        return f"exoleg {argv[1]}"
    return f"a Python program ({Path(argv[0]).name if argv and argv[0] else 'python'})"


def device_name(backend: str, interface: str | None, channel: str | None) -> str:
    """The real device a backend drives, as its lock names it: ``canopen:socketcan:can0``
    (a CAN interface and channel), ``ethercat:eth0`` (a network interface)."""
    if backend == "ethercat":
        return f"ethercat:{interface}"
    return f"{backend}:{interface}:{channel}"


def _holder(fd: int) -> dict[str, object]:
    os.lseek(fd, 0, os.SEEK_SET)
    try:
        said = json.loads(os.read(fd, 4096).decode("utf-8", errors="replace") or "{}")
    except ValueError:
        said = {}
    return said if isinstance(said, dict) else {}


def started_by(pid: int) -> bool:
    """Whether this process descends from ``pid``: its child, or a child of a process
    ``pid`` started (read from ``/proc``; where there is none, its parent only)."""
    p = os.getppid()
    for _ in range(64):  # a deeper tree is not a console's
        if p == pid:
            return True
        if p <= 1:
            return False
        try:  # pid (comm) state ppid ...: comm may hold spaces and parentheses
            stat = Path(f"/proc/{p}/stat").read_text()
            p = int(stat[stat.rindex(")") + 1:].split()[1])
        except (OSError, ValueError, IndexError):
            return False
    return False


def hold_device(name: str, what: str | None = None) -> int | None:
    """Hold the real device ``name`` (:func:`device_name`) for this process, as ``what``
    (the command, said to whoever is refused). Returns the lock's descriptor (close it to
    let go; the process's end lets go too), or None when a process it descends from
    holds it for it (the console whose session it is: :func:`started_by`). A
    ParameterError naming the holder when another process holds it; nothing has touched
    the bus then."""
    who = what or this_command()
    folder = lock_dir()
    path = folder / ("exoleg-device-" + re.sub(r"[^A-Za-z0-9_.-]", "_", name) + ".lock")
    try:
        fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
    except OSError as e:
        raise ParameterError(who, "--interface", f"cannot hold the device {name}: its lock "
                             f"file {path}: {e.strerror or e}") from None
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        holder = _holder(fd)
        os.close(fd)
        pid = holder.get("pid")
        if isinstance(pid, int) and started_by(pid):
            return None  # the interface that started this session holds it
        since = holder.get("since")
        when = (time.strftime(" since %Y-%m-%d %H:%M:%S", time.localtime(float(since)))
                if isinstance(since, (int, float)) else "")
        raise ParameterError(who, "--interface", f"the device {name} is held by "
                             f"{holder.get('what', 'another exoleg')} (process "
                             f"{holder.get('pid', '?')}){when}: one device, one console -- "
                             "end that one first (nothing was sent on the bus)") from None
    os.ftruncate(fd, 0)
    os.write(fd, json.dumps({"pid": os.getpid(), "what": who, "since": time.time(),
                             "argv": sys.argv[:8]}).encode())
    return fd


def let_go(fd: int | None) -> None:
    """Let go of a device :func:`hold_device` held (None: nothing to let go)."""
    if fd is not None:
        with contextlib.suppress(OSError):
            os.close(fd)
