"""The README's examples run exactly as written, in a fresh interpreter, after a plain
``import exoleg`` (the README's first Python block imports it; the others follow it as
a user pasting them in order would). Shell examples calling ``.venv/bin/exoleg`` run
with this interpreter's exoleg; ``make`` lines are what CI itself runs and are not
repeated here."""

from __future__ import annotations

import os
import re
import shlex
import signal
import subprocess
import sys
import time
from pathlib import Path

README = Path(__file__).resolve().parents[1] / "README.md"


def _blocks(lang: str) -> list[str]:
    return re.findall(rf"```{lang}\n(.*?)```", README.read_text(), re.S)


def test_readme_python_blocks_run_as_written(tmp_path: Path) -> None:
    blocks = _blocks("python")
    assert len(blocks) >= 3
    script = "\n\n".join(blocks)
    r = subprocess.run([sys.executable, "-c", script], cwd=tmp_path, capture_output=True,
                       text=True, check=False, timeout=600)
    assert r.returncode == 0, r.stderr
    assert (tmp_path / "leg.toml").exists() and (tmp_path / "leg.urdf").exists()


def test_readme_shell_commands_run_as_written(tmp_path: Path) -> None:
    import shutil

    # the commands run from a checkout: its examples/ folder is there
    shutil.copytree(README.parent / "examples", tmp_path / "examples")
    lines = [ln.split("#")[0].strip() for b in _blocks("sh") for ln in b.splitlines()]
    commands = [ln for ln in lines if ln.startswith(".venv/bin/exoleg ")]
    assert commands, "the README shows exoleg commands"
    for cmd in commands:
        argv = shlex.split(cmd)[1:]
        if argv[0] == "hmi":  # a server: it must start, answer, and stop on Ctrl-C
            _serves(argv, tmp_path)
            continue
        r = subprocess.run([sys.executable, "-m", "exoleg.cli", *argv], cwd=tmp_path,
                           capture_output=True, text=True, check=False, timeout=600)
        # the last lines of the output say how a session ended
        assert r.returncode == 0, (cmd, r.stderr, r.stdout[-1500:])
    make = [ln for ln in lines if ln.startswith("make ")]
    assert make[:2] == ["make simulate", "make test"]  # the two fresh-machine commands


def _serves(argv: list[str], cwd: Path) -> None:
    import httpx

    out = cwd / "hmi.txt"
    with out.open("w") as f:
        proc = subprocess.Popen([sys.executable, "-m", "exoleg.cli", *argv], cwd=cwd,
                                stdout=f, stderr=subprocess.STDOUT,
                                env={**os.environ, "PYTHONUNBUFFERED": "1"})
    try:
        deadline = time.time() + 60
        while not (m := re.search(r"operator interface: (\S+)/#token=", out.read_text())):
            assert proc.poll() is None and time.time() < deadline, out.read_text()
            time.sleep(0.05)
        assert httpx.get(m.group(1) + "/api/info", timeout=10).status_code == 200
        assert "E-STOP" in httpx.get(m.group(1) + "/", timeout=10).text
    finally:
        proc.send_signal(signal.SIGINT)
        assert proc.wait(timeout=30) == 130, out.read_text()
