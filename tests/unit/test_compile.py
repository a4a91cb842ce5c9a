"""``python -m exoleg.compile`` (run by ``make setup``): its jobs are commands a user
types, so each must stay one the command line accepts -- a job refused would leave its
kernels to compile on first use, every process at once (the suite's 70 s), unseen.
Reference: the command line's own parser (exoleg.cli.build_parser)."""

from __future__ import annotations

from pathlib import Path

import pytest

from exoleg.cli import build_parser
from exoleg.compile import FIT, JOBS, job_env


@pytest.mark.parametrize("label,args", [("fit", FIT), *JOBS], ids=lambda x: str(x)[:30])
def test_every_job_is_a_command_the_command_line_takes(label: str, args: tuple[str, ...],
                                                       tmp_path: Path) -> None:
    argv = [a.format(d=tmp_path / "d", child=tmp_path / "child.toml",
                     d0=tmp_path / "session.log") for a in args]
    ns = build_parser().parse_args(argv)  # exits (SystemExit 2) on what it refuses
    assert ns.command == argv[0]


def test_the_detectors_job_runs(tmp_path: Path) -> None:
    """The detector's job ran `exoleg detect SESSION --out DIR`, which the command refuses
    since its events must be a .csv (nothing of a session's is written over): make setup
    left the detector to compile on first use, and said so only in its log. Run as the
    job runs, on a short session of the simulated device."""
    from exoleg.cli import main

    label, args = next(j for j in JOBS if j[1][0] == "detect")
    assert main(["run", "--backend", "sim", "--duration", "0.5", "--no-realtime",
                 "--arm", "--walk-after", "0.1", "--out", str(tmp_path / "s")]) == 0
    argv = [a.format(d=tmp_path / "d", d0=tmp_path / "s" / "session.log") for a in args]
    assert main(argv) == 0, label


def test_the_sources_are_byte_compiled(tmp_path: Path) -> None:
    """Every module of the package has its bytecode beside it afterwards, at the path the
    import system reads it from (importlib's cache_from_source): with
    PYTHONDONTWRITEBYTECODE set (as on this machine) no process writes it on import. On
    a copy of the package without any, so that bytecode left by earlier runs (make setup
    writes it) cannot pass for this call's."""
    import importlib.util
    import shutil

    import exoleg
    from exoleg.compile import byte_compile

    copy = tmp_path / "exoleg"
    shutil.copytree(Path(exoleg.__file__).parent, copy,
                    ignore=shutil.ignore_patterns("__pycache__"))
    sources = list(copy.rglob("*.py"))
    assert len(sources) > 150  # the package, not an empty walk
    bytecode = [Path(importlib.util.cache_from_source(str(s))) for s in sources]
    assert not any(b.exists() for b in bytecode)
    assert byte_compile(copy)
    assert [s for s, b in zip(sources, bytecode, strict=True) if not b.exists()] == []


def test_the_jobs_sessions_are_not_held_to_time(monkeypatch: pytest.MonkeyPatch) -> None:
    """A job's session on a simulated device compiles; beside the other jobs compiling it
    fell behind and ended after 11 ticks (a fresh-clone CI run: "1 jobs failed ...: a
    session over CANopen", its last line the run's own, not an error), leaving its kernels
    to the suite. The jobs run with the simulated devices' loop-overrun limit at its
    largest (1000 ms: exoleg.runtime.session's range), unless the caller set one."""
    from exoleg.runtime.session import SIM_OVERRUN_ENV, simulated_overrun

    env = job_env({"PATH": "/bin"})
    assert env[SIM_OVERRUN_ENV] == "1000" and env["PATH"] == "/bin"
    assert env["MPLBACKEND"] == "Agg"
    assert job_env({SIM_OVERRUN_ENV: "500"})[SIM_OVERRUN_ENV] == "500"
    monkeypatch.setenv(SIM_OVERRUN_ENV, env[SIM_OVERRUN_ENV])
    assert simulated_overrun() == 1.0  # within the range the sessions accept
