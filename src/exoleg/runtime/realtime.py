"""What the loop asks of the operating system: SCHED_FIFO for its thread and, above it,
for the bus's threads; an isolated CPU where the kernel keeps one; a short GIL switch
interval (:func:`realtime_settings`), and the caller's settings put back afterwards
(:func:`saved_scheduling`)."""

from __future__ import annotations

import contextlib
import os
import sys
import threading
from collections.abc import Callable, Sequence
from pathlib import Path

#: SCHED_FIFO priorities: the loop's thread, and the bus's threads above it (their
#: answer is what the loop waits for, as a kernel's interrupt threads sit above the
#: tasks they wake)
LOOP_PRIORITY = 10
IO_PRIORITY = 11


def isolated_cpus(path: str = "/sys/devices/system/cpu/isolated") -> set[int]:
    """The CPUs the kernel keeps for pinned tasks (``isolcpus=``); empty when none."""
    cpus: set[int] = set()
    try:
        for part in filter(None, Path(path).read_text().strip().split(",")):
            lo, _, hi = part.partition("-")
            cpus.update(range(int(lo), int(hi or lo) + 1))
    except (OSError, ValueError):  # no such file, or not a CPU list: nothing isolated
        return set()
    return cpus


def realtime_settings(io_threads: Sequence[threading.Thread] = (),
                      period: float = 1e-3) -> list[str]:
    """Ask for SCHED_FIFO for this thread where the OS permits, and pin it to an isolated
    CPU if the kernel keeps one; the ``io_threads`` (the bus's receivers, the simulated
    nodes) get SCHED_FIFO above it, and a thread waiting for the GIL asks for it after a
    quarter ``period`` instead of CPython's 5 ms. Returns what was done.

    Measured on this 2-core VM with both CPUs busy (3 spinning processes), 10 s of the
    virtual CAN bus at 1 kHz, 5 ms bus timeout: with the loop pinned to a shared CPU
    and the bus threads at normal priority, every run lost a drive's answer within
    0.1 s; bus threads raised and the GIL's interval cut, 3 runs in 5 still did (the
    pinned loop cannot leave the CPU when the kernel gives it to other tasks for
    milliseconds); unpinned as well, 2 in 10 -- a stock kernel still stalls even a
    SCHED_FIFO thread ~5.5 ms then, hence the simulated nodes' longer bus timeout
    (:data:`exoleg.runtime.session.SIMULATED_BUS_TIMEOUT_S`)."""
    done = []
    if io_threads:
        switch = min(sys.getswitchinterval(), period / 4)
        sys.setswitchinterval(switch)
        done.append(f"GIL switch interval {switch * 1e6:.0f} us")
    with contextlib.suppress(AttributeError, OSError):
        cpus = isolated_cpus() & os.sched_getaffinity(0)
        if cpus:
            os.sched_setaffinity(0, {max(cpus)})
            done.append(f"pinned to isolated CPU {max(cpus)}")
        else:
            done.append("not pinned (no isolated CPU)")
    with contextlib.suppress(AttributeError, OSError):
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(LOOP_PRIORITY))
        done.append(f"SCHED_FIFO priority {LOOP_PRIORITY}")
    raised = 0
    for t in io_threads:
        with contextlib.suppress(AttributeError, OSError, TypeError):
            os.sched_setscheduler(t.native_id, os.SCHED_FIFO,  # type: ignore[arg-type]
                                  os.sched_param(IO_PRIORITY))
            raised += 1
    if raised:
        done.append(f"{raised} bus threads SCHED_FIFO priority {IO_PRIORITY}")
    return done


def saved_scheduling() -> Callable[[], None]:
    """What puts this thread's CPU affinity and scheduling policy, and the GIL's switch
    interval, back as they are now."""
    switch = sys.getswitchinterval()
    try:
        cpus, policy = os.sched_getaffinity(0), os.sched_getscheduler(0)
        param = os.sched_getparam(0)
    except (AttributeError, OSError):
        return lambda: sys.setswitchinterval(switch)

    def restore() -> None:
        sys.setswitchinterval(switch)
        with contextlib.suppress(OSError):
            os.sched_setscheduler(0, policy, param)
            os.sched_setaffinity(0, cpus)
    return restore
