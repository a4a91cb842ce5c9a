"""Benchmark: the runtime's 1 kHz loop on the ``sim`` backend -- how late each tick is.

Run: ``python benchmarks/bench_runtime.py [seconds]`` (default 60). Goal (issue 12): on
this 2-core VM, lateness p99 <= 200 us and no deadline missed by more than one period
in 60 s on ``sim``. Each tick: the simulated device's sensors, the walking controller
(supervisor, gait phases, impedance, safety), the drives and 2 plant steps, the
crash-safe log; the clock sleeps until 200 us before the deadline and spins the rest.
Printed twice: with CPU affinity and SCHED_FIFO (as root), and without.
The ``canopen`` and ``ethercat`` backends are not built yet.
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

from exoleg.runtime.session import run

SECONDS = float(sys.argv[1]) if len(sys.argv) > 1 else 60.0


def main() -> None:
    print(f"{'sim backend, ' + format(SECONDS, 'g') + ' s at 1 kHz':<36} {'p50 us':>8} "
          f"{'p99 us':>8} {'p99.9 us':>9} {'max us':>9} {'missed':>7}")
    for realtime in (True, False):
        with tempfile.TemporaryDirectory() as d:
            res, _ = run("sim", SECONDS, Path(d), arm=True, walk_after=1.0,
                         realtime=realtime)
        t = res.timing
        label = ("affinity + SCHED_FIFO: " + (", ".join(res.realtime) or "not permitted")
                 if realtime else "plain")
        print(f"{label:<36.36} {t['p50_us']:>8.1f} {t['p99_us']:>8.1f} {t['p999_us']:>9.1f} "
              f"{t['max_us']:>9.1f} {t['missed']:>7d}")
        print(f"  goal p99 <= 200 us: {'meets' if t['p99_us'] <= 200 else 'MISSES'}; "
              f"deadlines missed by more than a period: {t['missed']}")


if __name__ == "__main__":
    main()
