"""Benchmark: the clinician's report and the gait lab's exports on long sessions (issue 42).

Run: ``python benchmarks/bench_report.py``. Target (issue 42): a 10-minute session's
report (``exoleg report``: :func:`exoleg.plots.report.write_report`) within 5 s.

The sessions: a 12 s walking session of the simulated device (the runtime's own log),
its records repeated with each copy's clock moved on to 10 and 30 minutes at 1 kHz (as
the tests' ``tile_session`` does: what the runtime writes, 279 MB for 10 minutes). Timed:
the report of the 10-minute one; reading the 30-minute one for export, its C3D files
(at most 65,535 frames each) and its CSV. There is no like job in Pinocchio, MuJoCo or
OpenSim: the figure is against the target. Best of 3 after a first run.
"""

from __future__ import annotations

import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from conftest import tile_session  # noqa: E402  (the tests' long-session maker)
from exoleg.plots.report import write_report  # noqa: E402
from exoleg.runtime.exports import session_export, write_c3d, write_csv  # noqa: E402
from exoleg.runtime.session import run  # noqa: E402

TARGET_S = 5.0


def _best(job: Callable[[int], object], n: int = 3) -> float:
    job(-1)
    times = []
    for k in range(n):
        t0 = time.perf_counter()
        job(k)
        times.append(time.perf_counter() - t0)
    return min(times)


def main() -> None:
    with tempfile.TemporaryDirectory() as d:
        root = Path(d)
        run("sim", 12.0, root / "s", arm=True, walk_after=1.0, realtime=False)
        tile_session(root / "s", 600.0, root / "ten")
        took = _best(lambda k: write_report(root / "ten", root / f"ten{k}.pdf"))
        print(f"report of a 10-minute session: {took:.2f} s -- target <= {TARGET_S:g} s: "
              f"{'met' if took <= TARGET_S else 'NOT met'}")
        tile_session(root / "s", 1800.0, root / "thirty")
        took = _best(lambda k: session_export(root / "thirty"))
        ex = session_export(root / "thirty")
        print(f"reading a 30-minute session for export: {took:.2f} s ({len(ex.t):,} frames "
              f"of {len(ex.channels)} channels)")
        took = _best(lambda k: write_c3d(ex, root / f"thirty{k}.c3d"))
        print(f"its C3D files: {took:.2f} s")
        took = _best(lambda k: write_csv(ex, root / f"thirty{k}.csv"))
        print(f"its CSV: {took:.2f} s")


if __name__ == "__main__":
    main()
