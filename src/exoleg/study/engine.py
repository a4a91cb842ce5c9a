"""Running a study on Dask: its runs grouped into tasks, computed wherever the scheduler
puts them, each task's rows written as soon as it finishes -- one Parquet dataset, a row
per run, Hive-partitioned by one axis.

The folder a study writes (``exoleg sweep FILE --out DIR``)::

    DIR/study.toml          the study file as given (a resumed run must give the same)
    DIR/study.json          its name, runs, tasks, partition axis, exoleg's version
    DIR/data/AXIS=VALUE/task-000042.parquet   the rows (the study file and exoleg's
                            version in each file's metadata)
    DIR/.tasks/task-000042  a task is done once this exists (written after its rows)
    DIR/tasks.log           one line per task computed, in the order they finished

Resumable: a task whose marker exists is never computed again (an interrupted study
picks up where it stopped); the rows of a task that did not finish are written over.
Deterministic: the same study gives the same rows on any scheduler (a row holds no wall
time). A run that fails is a row with its error; a task whose worker died twice is a
row per run with the reason.

The scheduler: a Dask ``LocalCluster`` on this machine's cores (one single-threaded
worker process per core: the walks are compiled loops holding the interpreter), or an
existing cluster by its address (``tcp://host:port``) or scheduler file.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import logging
import os
import signal
import threading
import time
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any
from urllib.parse import quote

from exoleg.errors import ParameterError
from exoleg.study.runs import empty_row, run_task
from exoleg.study.spec import Runs, Study, check_room, count_runs

#: Tasks kept in flight per worker (the rest wait on this side: a study of a million
#: runs does not put a million futures on the scheduler).
IN_FLIGHT_PER_WORKER = 4


@dataclass(frozen=True)
class Outcome:
    """What :func:`execute` did: tasks in the study, done before it started, computed
    now; runs; the rows with an error; the dashboard's address (or ''); the tasks whose
    results a resumed study found damaged and computed again."""

    tasks: int
    already_done: int
    computed: int
    runs: int
    failed_runs: int
    dashboard: str
    damaged: tuple[int, ...] = ()


def task_count(study: Study) -> int:
    """How many tasks the study's runs make (without expanding them)."""
    return -(-count_runs(study) // study.runs_per_task)


class Tasks(Sequence[list[tuple[int, dict[str, Any]]]]):
    """The study's runs (run id, values) in tasks of ``runs_per_task``, in order, each
    task's runs built when the task is asked for (:class:`~exoleg.study.spec.Runs`): the
    first task of a study of millions of runs starts at once."""

    def __init__(self, study: Study) -> None:
        self.runs = Runs(study)
        self.k = study.runs_per_task

    def __len__(self) -> int:
        return -(-len(self.runs) // self.k)

    def __getitem__(self, t: int) -> list[tuple[int, dict[str, Any]]]:  # type: ignore[override]
        if not 0 <= t < len(self):
            raise IndexError(t)
        return [(i, self.runs[i]) for i in range(t * self.k,
                                                 min(len(self.runs), (t + 1) * self.k))]


def tasks_of(study: Study) -> Tasks:
    """The study's runs in tasks (:class:`Tasks`)."""
    return Tasks(study)


#: A study of at least this many runs has one of them timed before it starts
#: (:func:`seconds_per_run`): the 1-2 s it costs is then a small share of the study.
TIME_FROM_RUNS = 200


def seconds_per_run(study: Study) -> float:
    """How long one run of ``study`` takes on one core of this machine, s: its first run
    walked twice here, the second timed (the first loads the compiled functions, as
    each worker does once). The study's cost before it starts (``exoleg sweep``)."""
    from exoleg.study.runs import run_one

    run = Runs(study)[0]
    run_one(0, 0, run, study.strides, study.device or None)
    t0 = time.perf_counter()
    run_one(0, 0, run, study.strides, study.device or None)
    return time.perf_counter() - t0


def _marker(out: Path, task: int) -> Path:
    return out / ".tasks" / f"task-{task:06d}"


def done_tasks(out: str | Path) -> set[int]:
    """The tasks of the study in ``out`` whose rows are all written."""
    folder = Path(out) / ".tasks"
    if not folder.is_dir():
        return set()
    return {int(p.name.split("-")[1]) for p in folder.glob("task-*")
            if p.name.split("-")[1].isdigit()}


def damaged_tasks(out: str | Path) -> dict[int, list[Path]]:
    """The tasks of the study in ``out`` with a result file Parquet cannot read (cut,
    overwritten, not Parquet), and those files: task -> its files, every partition's."""
    import pyarrow.parquet as pq

    files: dict[int, list[Path]] = {}
    bad: set[int] = set()
    for f in sorted((Path(out) / "data").rglob("task-*.parquet")):
        stem = f.stem.split("-")[-1]
        if not stem.isdigit():
            continue
        files.setdefault(int(stem), []).append(f)
        try:
            pq.read_metadata(f)
        except Exception:  # noqa: BLE001  (pyarrow's ArrowInvalid, OSError: unreadable)
            bad.add(int(stem))
    return {t: files[t] for t in sorted(bad)}


def forget_tasks(out: Path, tasks: dict[int, list[Path]]) -> None:
    """Remove ``tasks``' result files and markers, so that the study computes them again."""
    for task, paths in tasks.items():
        for f in paths:
            f.unlink(missing_ok=True)
        _marker(out, task).unlink(missing_ok=True)


def check_folder(study: Study, out: str | Path) -> bool:
    """Whether ``out`` holds this study already (to resume); a folder that is a file,
    holds another study or anything else is refused (nothing written)."""
    folder = Path(out)
    if folder.exists() and not folder.is_dir():
        raise ParameterError(str(folder), "--out", "is a file; name a folder")
    held = folder / "study.toml"
    if held.exists():
        if held.read_bytes() != study.text.encode("utf-8"):
            raise ParameterError(str(folder), "--out", "holds another study (its "
                                 "study.toml differs): name another folder (nothing was "
                                 "written)")
        try:
            was = json.loads((folder / "study.json").read_text()).get("device", "")
        except (OSError, ValueError):  # unreadable: the shipped device's, as before
            was = ""
        if was != study.device:
            raise ParameterError(str(folder), "--device", "the study in this folder ran "
                                 f"on {was or 'the shipped device'}, not "
                                 f"{study.device or 'the shipped device'}: name another "
                                 "folder (nothing was written)")
        return True
    if folder.exists() and any(folder.iterdir()):
        raise ParameterError(str(folder), "--out", "is not empty and holds no study: name "
                             "an empty or new folder (nothing was written)")
    check_room(study, folder)
    return False


def prepare(study: Study, out: str | Path) -> Path:
    """The study's new folder, made and described (:func:`check_folder` first)."""
    folder = Path(out)
    held = folder / "study.toml"
    try:
        (folder / ".tasks").mkdir(parents=True, exist_ok=True)
        (folder / "data").mkdir(exist_ok=True)
    except OSError as e:
        raise ParameterError(str(folder), "--out", f"cannot be written: {e.strerror}") from None
    from exoleg import __version__
    from exoleg.io import atomic_path

    with atomic_path(folder / "study.json") as tmp:
        tmp.write_text(json.dumps({
            "name": study.name, "description": study.description,
            "runs": count_runs(study), "tasks": task_count(study),
            "sampling": study.sampling, "strides": study.strides,
            "partition_by": study.partition_by, "swept": study.swept,
            "device": study.device,
            "exoleg_version": __version__}, indent=2))
    with atomic_path(held) as tmp:  # last: a folder with study.toml is a study's
        tmp.write_text(study.text, encoding="utf-8")
    return folder


def _partition_value(row: dict[str, Any], axis: str) -> str:
    return quote(f"{row[axis]}", safe="")


def write_task(study: Study, out: Path, task: int, rows: list[dict[str, Any]]) -> None:
    """A task's rows into the dataset (one file per partition value it touches), then
    its marker."""
    import pyarrow as pa

    from exoleg import __version__
    from exoleg.io import signals_held, write_parquet_table

    axis = study.partition_by
    groups: dict[str, list[dict[str, Any]]] = {}
    for row in rows:
        key = f"{axis}={_partition_value(row, axis)}" if axis else ""
        groups.setdefault(key, []).append(row)
    meta = {b"exoleg.study": study.text.encode(), b"exoleg.version": __version__.encode()}
    for key, part in groups.items():
        cols = [{k: v for k, v in r.items() if k != axis} for r in part] if axis else part
        table = pa.Table.from_pylist(cols).replace_schema_metadata(meta)
        folder = out / "data" / key if key else out / "data"
        folder.mkdir(parents=True, exist_ok=True)
        write_parquet_table(table, folder / f"task-{task:06d}.parquet")
    with signals_held():  # the marker and its log line together, or neither
        _marker(out, task).write_text(f"{len(rows)} runs\n")
        with (out / "tasks.log").open("a", encoding="utf-8") as fh:
            fh.write(f"task {task} computed ({len(rows)} runs)\n")


def _key(study: Study, task: int) -> str:
    digest = hashlib.sha1(study.text.encode()).hexdigest()[:12]
    return f"exoleg-study-{digest}-task-{task:06d}"


def _reachable(scheduler: str) -> None:
    """A ``tcp://host:port`` that refuses connections fails at once (OSError), not after
    Dask's handshake timeout; one that accepts but does not answer as Dask's scheduler
    fails within :data:`SCHEDULER_ANSWER_S` (:func:`_answers_as_dask`)."""
    import socket
    from urllib.parse import urlsplit

    if scheduler.startswith(("tcp://", "tls://")):
        u = urlsplit(scheduler)
        if u.hostname is None or u.port is None:
            raise ValueError(f"expected {u.scheme}://HOST:PORT")
        if u.scheme == "tls":
            tls_security()  # the certificates first: without them Dask fails obscurely
        socket.create_connection((u.hostname, u.port), timeout=5.0).close()
        if u.scheme == "tcp":
            _answers_as_dask(scheduler)


def tls_security() -> Any:
    """Dask's TLS settings for a ``tls://`` scheduler, from Dask's configuration
    (``distributed.comm.tls``: ca-file, client.cert, client.key; or the
    ``DASK_DISTRIBUTED__COMM__TLS__...`` variables), or a ValueError saying what is
    missing."""
    from distributed.security import Security

    sec = Security()
    # (set from Dask's configuration at run time: the class declares no such attributes)
    missing = [k for k, a in (("ca-file", "tls_ca_file"), ("client.cert", "tls_client_cert"))
               if not getattr(sec, a, None)]
    if missing:
        raise ValueError("a tls:// scheduler needs Dask's TLS settings; "
                         f"distributed.comm.tls.{' and .'.join(missing)} not set (in Dask's "
                         "configuration, or DASK_DISTRIBUTED__COMM__TLS__CA_FILE, "
                         "..._CLIENT__CERT, ..._CLIENT__KEY)")
    return sec


#: How long a scheduler has to say who it is (s): a server that accepts the connection
#: and then says nothing (not Dask's) made Client wait forever.
SCHEDULER_ANSWER_S = 10.0


def _answers_as_dask(address: str) -> None:
    """The server at ``address`` answers Dask's identity call as a scheduler within
    :data:`SCHEDULER_ANSWER_S`, or a TimeoutError / ValueError saying what it did."""
    import asyncio

    from distributed.core import rpc

    async def identity() -> dict[str, Any]:
        async with rpc(address, timeout=SCHEDULER_ANSWER_S) as r:
            return dict(await r.identity())

    try:
        who = asyncio.run(asyncio.wait_for(identity(), SCHEDULER_ANSWER_S))
    except TimeoutError:  # asyncio.TimeoutError is this on Python 3.11+
        raise TimeoutError(f"the server accepted the connection but said nothing as Dask "
                           f"within {SCHEDULER_ANSWER_S:g} s") from None
    except Exception as e:  # the other end is not Dask's: what it did, in one line
        raise ValueError(f"it does not answer as Dask ({type(e).__name__})") from None
    if who.get("type") != "Scheduler":
        raise ValueError(f"it answers as a Dask {who.get('type', '?')}, not a scheduler")


def _interrupted_sync(record: logging.LogRecord) -> bool:
    """Whether the event loop's log keeps ``record``: not distributed's own slip on Ctrl-C
    (``distributed.utils.sync``, 2026.8: a Ctrl-C before its coroutine has started leaves
    ``cancel`` a name it never bound, and the loop logs that NameError with its
    traceback under the study's one line "interrupted: ... kept"). Nothing else."""
    exc = record.exc_info[1] if record.exc_info else None
    tb = exc.__traceback__ if exc is not None else None
    while tb is not None and tb.tb_next is not None:
        tb = tb.tb_next
    return not (isinstance(exc, NameError) and tb is not None
                and tb.tb_frame.f_code.co_name == "cancel"
                and tb.tb_frame.f_code.co_filename.endswith(("distributed/utils.py",
                                                             "distributed\\utils.py")))


@contextlib.contextmanager
def dask_client(scheduler: str | None = None, workers: int | None = None,
                processes: bool = True) -> Iterator[Any]:
    """A Dask client: on ``scheduler`` (an address ``tcp://host:port``, ``tls://host:port``
    with Dask's TLS settings, or a scheduler file), or on a ``LocalCluster`` of
    ``workers`` single-threaded processes (default: this machine's cores;
    ``processes=False``: threads in this process)."""
    from distributed import Client, LocalCluster

    logging.getLogger("distributed").setLevel(logging.ERROR)
    logging.getLogger("tornado.application").addFilter(_interrupted_sync)
    if scheduler:
        try:
            _reachable(scheduler)
            if Path(scheduler).is_file():
                try:
                    address = json.loads(Path(scheduler).read_text())["address"]
                except (OSError, ValueError, KeyError, TypeError):
                    raise ValueError("not a Dask scheduler file (JSON naming the "
                                     "scheduler's address)") from None
                _reachable(str(address))
                client = Client(scheduler_file=scheduler, timeout="10s")
            elif scheduler.startswith("tls://"):
                client = Client(scheduler, security=tls_security(), timeout="10s")
            else:
                client = Client(scheduler, timeout="10s")
        except (OSError, TimeoutError, ValueError, TypeError) as e:
            raise ParameterError("exoleg sweep", "--scheduler", f"{scheduler!r}: no Dask "
                                 f"scheduler answers there ({e})") from None
        try:
            yield client
        finally:
            client.close()
        return
    n = workers or os.cpu_count() or 1
    try:
        import bokeh  # noqa: F401  (the dashboard needs it)

        dashboard: str | None = "127.0.0.1:0"
    except ImportError:
        dashboard = None
    # worker processes talk over loopback TCP; threads in this process over inproc://
    where = {"host": "127.0.0.1"} if processes else {}
    # the workers start with SIGINT ignored (and keep it: a process started so leaves it
    # so): a Ctrl-C at a terminal reaches the whole process group, and only this process
    # is to answer it -- closing the cluster, keeping the tasks done -- not each worker
    # with a traceback
    main = threading.current_thread() is threading.main_thread()
    old = signal.signal(signal.SIGINT, signal.SIG_IGN) if main else None
    try:
        cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=processes,
                               dashboard_address=dashboard, silence_logs=logging.ERROR,
                               **where)
    finally:
        if main:
            signal.signal(signal.SIGINT, old)
    client = Client(cluster)
    try:
        yield client
    finally:
        client.close()
        cluster.close()


def execute(study: Study, out: str | Path, scheduler: str | None = None, *,
            client: Any = None, workers: int | None = None, processes: bool = True,
            on_progress: Callable[[int, int], None] | None = None,
            on_start: Callable[[str], None] | None = None) -> Outcome:
    """Run ``study`` into the folder ``out``, resuming it when it holds the same study.

    Parameters
    ----------
    study : Study
        The study (:func:`load_study`).
    out : str or Path
        Its folder: the Parquet dataset, the study's text and record.
    scheduler : str, optional
        A Dask scheduler's address or scheduler file; default a local cluster.
    client : distributed.Client, optional
        A client to use instead (:func:`dask_client`).
    workers : int, optional
        The local cluster's workers; default one per core.
    processes : bool, default True
        The local cluster's workers as processes (else threads).
    on_progress : callable, optional
        ``on_progress(done, total)`` after each task.
    on_start : callable, optional
        ``on_start(dashboard)`` once the scheduler answers (its dashboard's address, ''
        for none).

    Returns
    -------
    Outcome
        Tasks computed now and before, runs, runs with an error, the dashboard.
    """
    resuming = check_folder(study, out)  # refused before a cluster starts
    with (contextlib.nullcontext(client) if client is not None
          else dask_client(scheduler, workers, processes)) as c:
        # written once a scheduler answers
        folder = Path(out) if resuming else prepare(study, out)
        damaged = damaged_tasks(folder) if resuming else {}
        forget_tasks(folder, damaged)  # computed again below, with the tasks not done
        tasks = tasks_of(study)
        done = done_tasks(folder)
        todo = [t for t in range(len(tasks)) if t not in done]
        link = ""  # Dask names a link even where no dashboard serves (bokeh missing)
        with contextlib.suppress(Exception):
            if "dashboard" in c.scheduler_info().get("services", {}):
                link = str(c.dashboard_link or "")
        if on_start is not None:
            on_start(link)
        computed = _compute(c, study, folder, tasks, todo, len(done), on_progress)
    failed = _failed_runs(folder)
    return Outcome(tasks=len(tasks), already_done=len(done), computed=computed,
                   runs=count_runs(study), failed_runs=failed, dashboard=link,
                   damaged=tuple(damaged))


def _compute(client: Any, study: Study, folder: Path, tasks: Tasks, todo: list[int],
             done: int, on_progress: Callable[[int, int], None] | None) -> int:
    from distributed import as_completed

    workers = max(1, len(client.scheduler_info().get("workers", {})))
    window = IN_FLIGHT_PER_WORKER * workers
    queue = iter(todo)
    which: dict[Any, int] = {}

    def submit() -> Any:
        t = next(queue, None)
        if t is None:
            return None
        f = client.submit(run_task, t, tasks[t], study.strides, study.device or None,
                          key=_key(study, t),
                          pure=False, retries=1)
        which[f] = t
        return f

    first = [f for f in (submit() for _ in range(window)) if f is not None]
    computed = 0
    pending = as_completed(first)
    try:
        for fut in pending:
            t = which.pop(fut)
            try:
                rows = fut.result()
            except Exception as e:  # the worker died, twice: a row per run, with why
                rows = [{**empty_row(i, t, run), "error": f"task failed: {e!r}"}
                        for i, run in tasks[t]]
            write_task(study, folder, t, rows)
            computed += 1
            if on_progress is not None:
                on_progress(done + computed, len(tasks))
            nxt = submit()
            if nxt is not None:
                pending.add(nxt)
    except BaseException:
        client.cancel(list(which))
        raise
    return computed


def _failed_runs(folder: Path) -> int:
    table = read_results(folder, columns=["error"])
    return sum(1 for e in table.column("error").to_pylist() if e)


def read_results(out: str | Path, columns: list[str] | None = None) -> Any:
    """The study's rows, sorted by run (the partition axis a column again); what is
    written so far of an unfinished study.

    Parameters
    ----------
    out : str or Path
        The study's folder.
    columns : list of str, optional
        The columns to read; default all.

    Returns
    -------
    pyarrow.Table
    """
    import pyarrow.dataset as ds

    folder = Path(out) / "data"
    if not folder.is_dir():
        raise ParameterError(str(out), "(study)", "holds no study results (no data/ folder)")
    try:
        dataset = ds.dataset(folder, format="parquet", partitioning="hive")
        table = dataset.to_table(columns=None if columns is None else
                                 [*columns, *(["run"] if "run" not in columns else [])])
    except Exception:  # noqa: BLE001  (pyarrow's ArrowInvalid, OSError)
        damaged = damaged_tasks(out)
        if not damaged:
            raise
        names = [str(f.relative_to(out)) for fs in damaged.values() for f in fs]
        raise ParameterError(str(out), "data/", f"{len(names)} result file(s) damaged "
                             f"({', '.join(names[:3])}{', ...' if len(names) > 3 else ''}): "
                             "run the study again with the same file and --out; it "
                             "computes those tasks again") from None
    if table.num_rows:
        table = table.sort_by("run")
    return table if columns is None else table.select(columns)
