"""Benchmark: the runtime's 1 kHz loop on the ``sim`` backend -- how late each tick is.

Run: ``python benchmarks/bench_runtime.py [seconds]`` (default 60). Goal (issue 12): on
this 2-core VM, lateness p99 <= 200 us and no deadline missed by more than one period
in 60 s on ``sim``. Each tick: the simulated device's sensors, the walking controller
(supervisor, gait phases, impedance, safety), the drives and 2 plant steps, the
crash-safe log; the clock sleeps until 200 us before the deadline and spins the rest.
Printed for the ``sim`` backend with the real-time settings (SCHED_FIFO as root, an
isolated CPU if the kernel keeps one, the bus's threads above the loop) and without,
and for the ``canopen`` backend on the virtual bus (hardware in the loop: 3 RPDOs, SYNC,
3 TPDOs and 2 foot-board frames per tick through python-canopen/python-can, the
simulated nodes answering from the bus's notifier thread), with its bus round trip, and
for the ``ethercat`` backend against its simulated segment (process data only: no
network interface, so its bus time is the master's packing plus the simulated plant,
not a wire's).
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

from exoleg.runtime.session import run

SECONDS = float(sys.argv[1]) if len(sys.argv) > 1 else 60.0


def main() -> None:
    import numpy as np

    from exoleg.session_log import read_log

    print(f"{format(SECONDS, 'g') + ' s at 1 kHz, lateness':<36} {'p50 us':>8} "
          f"{'p99 us':>8} {'p99.9 us':>9} {'max us':>9} {'missed':>7}")
    for backend, realtime in (("sim", True), ("sim", False), ("canopen", True),
                              ("ethercat", True)):
        with tempfile.TemporaryDirectory() as d:
            res, path = run(backend, SECONDS, Path(d), arm=True, walk_after=1.0,
                            realtime=realtime)
            bus = read_log(path)[1].get("bus_us")
        t = res.timing
        label = backend + (": SCHED_FIFO" if realtime and res.realtime else ": plain")
        print(f"{label:<36.36} {t['p50_us']:>8.1f} {t['p99_us']:>8.1f} {t['p999_us']:>9.1f} "
              f"{t['max_us']:>9.1f} {t['missed']:>7d}")
        print(f"  goal p99 <= 200 us: {'meets' if t['p99_us'] <= 200 else 'MISSES'}; "
              f"deadlines missed by more than a period: {t['missed']}; ended by "
              f"{res.stopped_by}" + (f"; {', '.join(res.realtime)}" if res.realtime else ""))
        if bus is not None:
            what = ("RPDOs + SYNC -> every node's answer" if backend == "canopen" else
                    "outputs -> one process-data exchange -> inputs")
            print(f"  bus round trip ({what}): p50 "
                  f"{np.percentile(bus, 50):.0f} us, p99 {np.percentile(bus, 99):.0f} us, max "
                  f"{bus.max():.0f} us")


if __name__ == "__main__":
    main()
