"""Compile exoleg's kernels into numba's on-disk cache before their first use
(``python -m exoleg.compile``; ``make setup`` runs it after installing).

exoleg's tick, plant, child, detector and studies are numba functions compiled on their
first call and cached beside their source (``cache=True``). On a fresh install that
first call is slow: the walking device's kernels take 25 s on this 2-core machine, the
paper's scenario 5 s, each command's own more. A session's loop compiles what it needs
before its clock starts (:meth:`exoleg.runtime.loop.Device.warm_up`), so nothing is
ever late; but the first ``exoleg simulate --walk`` a clinic runs would wait, and every
process that starts on the empty cache at the same time compiles the same code again
(the test suite's workers and the commands they start: 70 s of its wall time).

This runs each command that compiles something on a small job of its own -- the paper's
scenario and its actuators, a walk in every support mode with a fitted child as an actor,
sessions on the simulated device and both simulated buses, the population batch,
identification, the detector (:data:`JOBS`) -- in as many processes at once as CPUs
(numba's cache is safe across processes: :mod:`exoleg._cache`). The kernels are those
the commands use, with the types they are called with; a source edited later recompiles
on its next use as before. Its own output goes to a temporary folder and is removed.

It byte-compiles the package's sources first (:func:`byte_compile`): an editable install
has none, and with ``PYTHONDONTWRITEBYTECODE`` set no process writes them, so every
process that imports exoleg (a session, the console, each command) would compile its
sources again -- 0.1 s of CPU each, measured on the console's and a session's imports."""

from __future__ import annotations

import compileall
import logging
import os
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

log = logging.getLogger(__name__)

#: (label, the command's arguments after ``exoleg``) with ``{d}`` the job's folder,
#: ``{child}`` the fitted child's file and ``{d0}`` the first job's session log; in the
#: order they are started (beside the first, the jobs whose kernels it does not compile)
JOBS: tuple[tuple[str, tuple[str, ...]], ...] = (
    ("walking with a child", ("run", "--backend", "sim", "--duration", "0.3", "--arm",
                              "--walk-after", "0.1", "--child", "{child}", "--no-realtime",
                              "--out", "{d}")),
    ("the paper's scenario", ("simulate", "--duration", "0.5", "--out", "{d}")),
    ("the paper's actuators", ("simulate", "--actuators", "--duration", "0.5", "--no-engine",
                               "--out", "{d}")),
    ("the population", ("population", "--ages", "10", "--percentiles", "50", "--out", "{d}")),
    ("transparent walk", ("simulate", "--walk", "--strides", "1", "--controller",
                          "transparent", "--child", "{child}", "--out", "{d}")),
    ("assist-as-needed walk", ("simulate", "--walk", "--strides", "1", "--controller", "aan",
                               "--child", "{child}", "--out", "{d}")),
    ("impedance walk", ("simulate", "--walk", "--strides", "1", "--out", "{d}")),
    ("a session on the simulated device", ("run", "--backend", "sim", "--duration", "0.3",
                                           "--arm", "--walk-after", "0.1", "--no-realtime",
                                           "--out", "{d}")),
    ("a session over CANopen", ("run", "--backend", "canopen", "--interface", "virtual",
                                "--duration", "0.3", "--arm", "--walk-after", "0.1",
                                "--no-realtime", "--out", "{d}")),
    ("a session over EtherCAT", ("run", "--backend", "ethercat", "--interface", "fake",
                                 "--duration", "0.3", "--arm", "--walk-after", "0.1",
                                 "--no-realtime", "--out", "{d}")),
    ("pd-gravity session", ("run", "--backend", "sim", "--controller", "pd-gravity",
                            "--duration", "0.3", "--arm", "--no-realtime", "--out", "{d}")),
    ("identification", ("identify", "--backend", "sim", "--duration", "10", "--no-realtime",
                        "--out", "{d}")),
    ("the detector", ("detect", "{d0}", "--out", "{d}.csv")),
)
#: the job that writes the child file the others use
FIT = ("fit", "--age", "10", "--sex", "female", "--height", "138", "--mass", "32",
       "--gmfcs", "2", "--spasticity", "moderate", "--no-simulate", "--out", "{d}")


def _exoleg(args: list[str], env: dict[str, str]) -> tuple[int, str]:
    """Run ``exoleg args``: its exit status and why it failed -- its error's last line,
    else its output's first (a session that ended early says how there: ``exoleg run``'s
    summary), else the status itself."""
    r = subprocess.run([sys.executable, "-m", "exoleg.cli", *args], capture_output=True,
                       text=True, env=env, check=False)
    err, out = r.stderr.strip().splitlines(), r.stdout.strip().splitlines()
    return r.returncode, err[-1] if err else out[0] if out else f"exit status {r.returncode}"


def job_env(environ: dict[str, str]) -> dict[str, str]:
    """The jobs' environment: ``environ`` with matplotlib off screen and a simulated
    device's loop-overrun limit at its largest
    (:data:`~exoleg.runtime.session.SIM_OVERRUN_ENV`, unless set): a job's session is
    there to compile, not to keep time, and beside the other jobs compiling it fell behind
    (a fresh install's CANopen job: 10 ticks in a row 3-6 ms late, the session ended after
    11 ticks -- its kernels then compiled on first use, in the test suite's sessions)."""
    from exoleg.runtime.session import SIM_OVERRUN_ENV, SIM_OVERRUN_RANGE_MS

    return {SIM_OVERRUN_ENV: f"{SIM_OVERRUN_RANGE_MS[1]:g}", **environ, "MPLBACKEND": "Agg"}


def byte_compile(root: Path = Path(__file__).parent) -> bool:
    """Write the bytecode of the sources under ``root`` (default: the package) beside them
    (``__pycache__``, as an install from a wheel does; a source edited later is compiled
    again on import as before); whether every file compiled."""
    return bool(compileall.compile_dir(root, quiet=1))


def compile_all(jobs: int | None = None) -> list[str]:
    """Run :data:`JOBS` in ``jobs`` processes at once (default: the CPUs this process
    may use), each said as it ends (logging, INFO); returns the jobs that failed, each
    with why (:func:`_exoleg`; a job's failure leaves that command to compile on first
    use: nothing else depends on it)."""
    jobs = jobs or len(os.sched_getaffinity(0))
    env = job_env(dict(os.environ))
    failed: list[str] = [] if byte_compile() else ["byte-compiling the sources"]
    with tempfile.TemporaryDirectory(prefix="exoleg-compile-") as tmp:
        root = Path(tmp)
        t0 = time.perf_counter()
        code, err = _exoleg([a.format(d=root / "fit") for a in FIT], env)
        child = root / "fit" / "child.toml"
        if code != 0 or not child.exists():
            failed.append(f"fitting a child: {err}")
        first = root / "job0"

        def one(k: int) -> str | None:
            label, args = JOBS[k]
            if "{child}" in args and not child.exists():
                return None
            code, err = _exoleg([a.format(d=root / f"job{k}", child=child, d0=first / "session.log")
                                 for a in args], env)
            log.info("exoleg.compile: %s: %s (%.0f s)", label,
                     "done" if code == 0 else "FAILED", time.perf_counter() - t0)
            return None if code == 0 else f"{label}: {err}"

        with ThreadPoolExecutor(jobs) as pool:
            failed += filter(None, pool.map(one, range(len(JOBS) - 1)))
        # the detector's job reads the first job's session: last
        failed += filter(None, [one(len(JOBS) - 1)])
    return failed


def main() -> int:
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    t0 = time.perf_counter()
    failed = compile_all()
    log.info("exoleg.compile: numba's cache filled in %.0f s%s", time.perf_counter() - t0,
             f"; {len(failed)} jobs failed (they compile on first use): " + "; ".join(failed)
             if failed else "")
    return 0


if __name__ == "__main__":
    sys.exit(main())
