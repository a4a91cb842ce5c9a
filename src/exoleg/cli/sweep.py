"""``exoleg sweep``: a study over children, device variants, controllers and walks, on
Dask (this machine's cores, or an existing cluster), into one Parquet dataset; and its
summary over any two axes."""

from __future__ import annotations

import argparse
import signal
import sys
import time
from pathlib import Path
from typing import Any

from exoleg.cli._common import _count, _device_option, _say, _table


def cmd_sweep(args: argparse.Namespace) -> int:
    from exoleg.errors import ParameterError

    if args.summary:
        if args.study or args.out or args.scheduler or args.workers or args.device:
            raise ParameterError("exoleg sweep", "--summary", "reads a study's folder: give "
                                 "it alone (with --x, --y), not a study file, --out, "
                                 "--scheduler, --workers or --device (the study's runs "
                                 "already hold their device)")
        return _summary(args)
    if args.x or args.y:
        raise ParameterError("exoleg sweep", "--x/--y", "go with --summary DIR")
    if not args.study or not args.out:
        raise ParameterError("exoleg sweep", "FILE/--out", "give the study file and --out "
                             "DIR (or --summary DIR)")
    if args.scheduler and args.workers:
        raise ParameterError("exoleg sweep", "--workers", "sizes the local cluster: not "
                             "with --scheduler (the cluster has its own workers)")
    return _run(args)


def _run(args: argparse.Namespace) -> int:
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TimeRemainingColumn

    from exoleg.study.engine import done_tasks, execute, task_count
    from exoleg.study.spec import count_runs, load_study

    study = load_study(args.study)
    if args.device is not None:
        from exoleg.device.files import check_folder

        study = study.on_device(str(check_folder(args.device).resolve()))
    n_tasks = task_count(study)
    before = len(done_tasks(args.out)) if (Path(args.out) / "study.toml").exists() else 0
    where = args.scheduler or f"a local Dask cluster ({args.workers or 'one worker per core'})"
    n_runs = count_runs(study)
    _say(f"exoleg sweep: study '{study.name}', {n_runs:,} runs of "
         f"{study.strides} strides in {n_tasks:,} tasks"
         + (f" ({before} done: resuming)" if before else "") + f", on {where}")
    _say(_cost(study, n_runs, n_tasks - before, args))
    t0 = time.perf_counter()
    # SIGTERM as Ctrl-C: the cluster closes and the tasks done are kept (this process only
    # orchestrates: no compiler callback for the exception to land in)
    old = signal.signal(signal.SIGTERM, _as_interrupt)
    with Progress("[progress.description]{task.description}", BarColumn(),
                  MofNCompleteColumn(), TimeRemainingColumn(), transient=False) as bar:
        job = bar.add_task("tasks", total=n_tasks, completed=before)
        try:
            outcome = execute(study, args.out, args.scheduler, workers=args.workers,
                              on_progress=lambda d, _t: bar.update(job, completed=d),
                              on_start=_dashboard)
        except KeyboardInterrupt:
            bar.stop()
            done = len(done_tasks(args.out))
            print(f"exoleg: interrupted: {done} of {n_tasks} tasks done and kept in "
                  f"{args.out}; run the same command to go on (no task is computed "
                  "twice)", file=sys.stderr)
            return 130
        finally:
            signal.signal(signal.SIGTERM, old)
    wall = time.perf_counter() - t0
    if outcome.damaged:
        _say(f"task(s) {', '.join(map(str, outcome.damaged))} had damaged result files "
             "(unreadable Parquet): computed again")
    _say(f"{outcome.computed} tasks computed now, {outcome.already_done} before; "
         f"{outcome.runs:,} runs, {outcome.failed_runs} with an error; {wall:.1f} s")
    _say(f"wrote {args.out}/ (data/: Parquet, a row per run; study.toml, study.json); "
         f"summary: exoleg sweep --summary {args.out}")
    return 0


def _cost(study: Any, n_runs: int, todo_tasks: int, args: argparse.Namespace) -> str:
    """The study's cost said before it starts: its results on disk and, for a study of
    :data:`~exoleg.study.engine.TIME_FROM_RUNS` runs or more, its time -- one run timed
    here, times the runs left, over the workers (a cluster's: per core)."""
    import os

    from exoleg.study.engine import TIME_FROM_RUNS, seconds_per_run
    from exoleg.study.spec import ROW_BYTES

    left = min(n_runs, todo_tasks * study.runs_per_task)
    size = f"cost: results about {n_runs * ROW_BYTES / 1e6:,.1f} MB"
    if n_runs < TIME_FROM_RUNS:
        return size + "; timed as its tasks finish (the bar's time left)"
    per = seconds_per_run(study)
    if args.scheduler:
        return (size + f"; one run takes {per:.2f} s on a core here (measured): "
                f"{left:,} runs, about {_duration(left * per)} of one core's time")
    workers = args.workers or os.cpu_count() or 1
    return (size + f"; one run takes {per:.2f} s on a core here (measured): {left:,} runs "
            f"on {workers} worker(s), about {_duration(left * per / workers)}")


def _duration(s: float) -> str:
    """A duration as people read it: 45 s, 12 min, 3.2 h, 4.1 days."""
    if s < 90:
        return f"{s:.0f} s"
    if s < 5400:
        return f"{s / 60:.0f} min"
    if s < 172800:
        return f"{s / 3600:.1f} h"
    return f"{s / 86400:.1f} days"


def _dashboard(link: str) -> None:
    _say(f"Dask's dashboard: {link}" if link else "Dask's dashboard: none (bokeh is not "
         "installed where the scheduler runs)")


def _as_interrupt(signum: int, frame: object) -> None:
    raise KeyboardInterrupt


def _summary(args: argparse.Namespace) -> int:
    import csv

    from exoleg.io import OutputFolder
    from exoleg.plots.sweep import heatmap
    from exoleg.study.summary import CELL, summarise

    s = summarise(args.summary, args.x, args.y)
    rows = s.rows()
    _table([[str(r[s.x]), str(r[s.y])] + [_fmt(r[c]) for c in CELL] for r in rows],
           [s.x, s.y, *CELL], title=f"study {args.summary}: over {s.x} and {s.y}")
    stem = f"summary-{s.x}-{s.y}"
    with OutputFolder(args.summary, owner="exoleg sweep") as out:
        with out.stage(f"{stem}.csv").open("w", newline="") as fh:
            w = csv.DictWriter(fh, fieldnames=list(rows[0]))
            w.writeheader()
            w.writerows(rows)
        heatmap(s, out.stage(f"{stem}.png"))
        out.commit()
    _say(f"wrote {args.summary}/{stem}.csv and {stem}.png")
    return 0


def _fmt(v: Any) -> str:
    return f"{v:.3g}" if isinstance(v, float) else str(v)


def add_parser(sub: Any) -> None:
    """Add ``exoleg sweep`` to the subcommands ``sub``."""
    s = sub.add_parser("sweep", help="a study over children, device variants, controllers "
                       "and walks, on Dask; or its summary")
    s.add_argument("study", nargs="?", type=Path, help="the study file (TOML; "
                   "examples/sweep-small.toml)")
    s.add_argument("--out", type=Path, help="the study's folder (a new one, or the same "
                   "study's to resume it)")
    s.add_argument("--scheduler", help="an existing Dask scheduler: its address "
                   "(tcp://host:port) or scheduler file (default: a local cluster)")
    s.add_argument("--workers", type=_count(1, 256), help="the local cluster's worker "
                   "processes (default: one per core)")
    s.add_argument("--summary", type=Path, metavar="DIR", help="summarise a study's folder "
                   "over two axes (--x, --y; default its first two swept axes)")
    s.add_argument("--x", help="with --summary: the axis across")
    s.add_argument("--y", help="with --summary: the axis up")
    _device_option(s, "every run's actuators, gains, sensors, safety limits and ground (the "
                      "folder must be readable where the workers run; its actuation is "
                      "fixed: a study naming hip_motor, bus_voltage or a ratio is refused)")
    s.set_defaults(func=cmd_sweep)
