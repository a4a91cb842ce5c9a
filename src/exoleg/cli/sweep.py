"""``exoleg sweep``: a study over children, device variants, controllers and walks, on
Dask (this machine's cores, or an existing cluster), into one Parquet dataset; and its
summary over any two axes."""

from __future__ import annotations

import argparse
import dataclasses
import signal
import sys
import time
from pathlib import Path
from typing import Any

from exoleg.cli._common import _count, _device_option, _say, _table


def cmd_sweep(args: argparse.Namespace) -> int:
    from exoleg.errors import ParameterError

    if args.summary:
        if args.study or args.out or args.scheduler or args.workers:
            raise ParameterError("exoleg sweep", "--summary", "reads a study's folder: give "
                                 "it alone (with --x, --y), not a study file, --out, "
                                 "--scheduler or --workers")
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

        study = dataclasses.replace(study, device=str(check_folder(args.device).resolve()))
    n_tasks = task_count(study)
    before = len(done_tasks(args.out)) if (Path(args.out) / "study.toml").exists() else 0
    where = args.scheduler or f"a local Dask cluster ({args.workers or 'one worker per core'})"
    _say(f"exoleg sweep: study '{study.name}', {count_runs(study):,} runs of "
         f"{study.strides} strides in {n_tasks:,} tasks"
         + (f" ({before} done: resuming)" if before else "") + f", on {where}")
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
    _say(f"{outcome.computed} tasks computed now, {outcome.already_done} before; "
         f"{outcome.runs:,} runs, {outcome.failed_runs} with an error; {wall:.1f} s")
    _say(f"wrote {args.out}/ (data/: Parquet, a row per run; study.toml, study.json); "
         f"summary: exoleg sweep --summary {args.out}")
    return 0


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
                      "folder must be readable where the workers run)")
    s.set_defaults(func=cmd_sweep)
