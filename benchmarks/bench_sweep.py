"""Benchmark: a study through Dask against the same runs as a bare batch (issue 26).

Run: ``python benchmarks/bench_sweep.py [RUNS]`` (default 10,000). Target (issue 26):
simulated seconds per wall second through Dask >= 80 % of the bare batch's on this
machine's cores.

* the study: RUNS walking runs of one stride after 1 s of standing (2.1 s simulated
  each), the design range's ages x noise seeds, 50 runs a task;
* Dask: :func:`exoleg.study.engine.execute` on a ``LocalCluster`` of one single-threaded
  worker process per core, rows written to Parquet as each task finishes -- end to end,
  the cluster's start and the workers' loading of the compiled code included, and the
  compute window alone (the first task's end to the last's, per task between them);
* bare batch: the same tasks (:func:`exoleg.study.runs.run_task`) in a
  ``ProcessPoolExecutor`` of as many processes, rows kept in memory;
* the overhead per task (Dask's wall less the bare batch's, over the tasks) and walking
  runs per second per core (the bare batch's).
"""

from __future__ import annotations

import os
import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

from exoleg.study.engine import execute, tasks_of
from exoleg.study.runs import run_task
from exoleg.study.spec import parse_study


def study_text(runs: int) -> str:
    seeds = max(2, runs // 5)
    return (f"[study]\nname = \"bench\"\nstrides = 1\nruns_per_task = 50\n[axes]\n"
            f"age = [8, 9, 10, 11, 12]\nseed = {{min = 0, max = {seeds - 1}, "
            f"steps = {seeds}}}\n")


def _warm(_: int) -> int:
    """Compile (or load from numba's cache) in a pool process before the clock."""
    run_task(0, [(0, parse_study(study_text(10)).runs()[0])], 1)
    return os.getpid()


def main() -> None:
    runs = int(sys.argv[1]) if len(sys.argv) > 1 else 10_000
    study = parse_study(study_text(runs), "bench")
    tasks = tasks_of(study)
    n = len(study.runs())
    cores = os.cpu_count() or 1
    simulated = n * (1.0 + study.strides * 1.1)
    # the bare batch
    with ProcessPoolExecutor(cores) as pool:
        list(pool.map(_warm, range(cores)))
        t0 = time.perf_counter()
        list(pool.map(run_task, range(len(tasks)), tasks, [study.strides] * len(tasks)))
        bare = time.perf_counter() - t0
    # Dask, end to end and the compute window
    marks: list[float] = []
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        execute(study, Path(tmp) / "study", workers=cores,
                on_progress=lambda d, _t: marks.append(time.perf_counter()))
        dask_total = time.perf_counter() - t0
    # the compute window: the first to the last task's end, over the tasks between them
    window = (marks[-1] - marks[0]) * len(tasks) / max(1, len(tasks) - 1)
    print(f"{n:,} walking runs of 2.1 s simulated ({simulated:,.0f} s) in {len(tasks)} "
          f"tasks on {cores} cores")
    print(f"{'':38}{'wall':>10}{'sim s / wall s':>16}{'vs bare':>10}")
    print(f"{'bare batch (process pool)':38}{bare:>9.1f}s{simulated / bare:>16.0f}"
          f"{'100 %':>10}")
    print(f"{'Dask LocalCluster, compute window':38}{window:>9.1f}s"
          f"{simulated / window:>16.0f}{100 * bare / window:>9.0f}%")
    print(f"{'Dask LocalCluster, end to end':38}{dask_total:>9.1f}s"
          f"{simulated / dask_total:>16.0f}{100 * bare / dask_total:>9.0f}%")
    print(f"overhead per task (end to end): {1e3 * (dask_total - bare) / len(tasks):.1f} ms; "
          f"walking runs per second per core: {n / bare / cores:.1f}")
    ratio = bare / dask_total
    print(f"target: Dask >= 80 % of the bare batch's simulated seconds per wall second: "
          f"{100 * ratio:.0f} % ({'meets' if ratio >= 0.8 else 'misses'})")


if __name__ == "__main__":
    main()
