"""The README's and the guides' examples run exactly as written: each page's blocks in
its order, from a fresh folder holding the checkout's ``examples/``, as a user pasting
them would -- its Python blocks in one fresh interpreter (after a plain ``import
exoleg``, which the page's first block does), its ``.venv/bin/exoleg`` lines run in the
same interpreter as the console command runs them (:func:`exoleg.cli.main`), each of
which must succeed (or end as its comment says: ``# exit 1: ...``).
``make`` lines are what CI itself runs and are not repeated here; ``exoleg hmi`` (a
server) must start, answer and stop on Ctrl-C."""

from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path

import pytest

from conftest import EXOLEG

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
PAGES = [README, *sorted(p for p in (ROOT / "docs" / "guides").glob("*.md")
                         if p.stem != "index"),
         *sorted((ROOT / "docs" / "extending").glob("*.md"))]
FENCE = re.compile(r"^```(\w*)\n(.*?)^```", re.S | re.M)

#: runs one page's blocks in order in this (fresh) interpreter: Python blocks in one
#: namespace, shell lines as exoleg commands, a server started, asked and interrupted
RUNNER = r'''
import contextlib, io, json, os, re, shlex, signal, subprocess, sys, time
blocks = json.loads(sys.argv[1])
ns = {"__name__": "__main__"}
for i, (lang, code) in enumerate(blocks):
    if lang == "python":
        exec(compile(code, f"<{sys.argv[2]} block {i}>", "exec"), ns)
        continue
    for line in code.splitlines():
        line, _, comment = line.partition("#")
        line = line.strip()
        if not line.startswith(".venv/bin/exoleg "):
            continue
        # a command the page says ends otherwise ("# exit 1: ...") must end so
        said = re.match(r"\s*exit (\d+)", comment)
        expected = int(said.group(1)) if said else 0
        args = shlex.split(line)[1:]
        if args[0] != "hmi":
            # as the console command runs it (exoleg.cli.main), in this interpreter
            from exoleg.cli import main
            out, err = io.StringIO(), io.StringIO()
            with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
                try:
                    code = main(args)
                except SystemExit as e:
                    code = e.code if isinstance(e.code, int) else 1
            if code != expected:
                sys.exit(f"{line}\nexit {code}, the page says {expected}\n"
                         f"{err.getvalue()}\n{out.getvalue()[-1500:]}")
            continue
        import httpx
        with open("hmi.txt", "w") as f:  # the console command itself (conftest.EXOLEG)
            proc = subprocess.Popen([sys.argv[4], *args], stdout=f, stderr=subprocess.STDOUT,
                                    env={**os.environ, "PYTHONUNBUFFERED": "1"})
        deadline = time.time() + 60
        while not (m := re.search(r"operator interface: (\S+)/#token=", open("hmi.txt").read())):
            assert proc.poll() is None and time.time() < deadline, open("hmi.txt").read()
            time.sleep(0.05)
        assert httpx.get(m.group(1) + "/api/info", timeout=10).status_code == 200
        assert "E-STOP" in httpx.get(m.group(1) + "/", timeout=10).text
        proc.send_signal(signal.SIGINT)
        assert proc.wait(timeout=30) == 130, open("hmi.txt").read()
# the pictures the page shows that its own code drew: refreshed into EXOLEG_DOCS_IMG
import shutil
for name in re.findall(r"\]\(\.\./img/([\w.-]+)\)", open(sys.argv[3]).read()):
    if os.path.exists(name) and os.environ.get("EXOLEG_DOCS_IMG"):
        shutil.copy(name, os.path.join(os.environ["EXOLEG_DOCS_IMG"], name))
'''


def blocks(page: Path) -> list[tuple[str, str]]:
    """A page's fenced blocks that run: Python, and shell (``sh``)."""
    return [(lang, code) for lang, code in FENCE.findall(page.read_text())
            if lang in ("python", "sh")]


@pytest.mark.parametrize("page", PAGES, ids=[p.stem for p in PAGES])
def test_page_runs_as_written(page: Path, tmp_path: Path) -> None:
    import shutil

    shutil.copytree(ROOT / "examples", tmp_path / "examples")
    code = blocks(page)
    assert any(lang == "python" for lang, _ in code) or any(
        ".venv/bin/exoleg " in c for _, c in code), f"{page.name} shows nothing that runs"
    r = subprocess.run([sys.executable, "-c", RUNNER, json.dumps(code), page.name, str(page),
                        EXOLEG],
                       cwd=tmp_path, capture_output=True, text=True, check=False,
                       timeout=900)
    assert r.returncode == 0, (page.name, r.stderr[-4000:], r.stdout[-1500:])
    # every picture the page shows is in docs/img; one its own code draws, it drew
    for name in re.findall(r"\]\(\.\./img/([\w.-]+)\)", page.read_text()):
        assert (ROOT / "docs" / "img" / name).exists(), name
        if name.startswith(page.stem + "-"):  # drawn by this page's code
            assert (tmp_path / name).stat().st_size > 10_000, name


def test_readme_is_a_landing_page() -> None:
    """The README starts with the two fresh-machine commands (the main job, the tests),
    stays within 120 lines (issue 43), and its Python example made the files it says."""
    text = README.read_text()
    make = [ln.split("#")[0].strip() for lang, c in blocks(README) if lang == "sh"
            for ln in c.splitlines() if ln.startswith("make ")]
    assert make[:2] == ["make simulate", "make test"]
    assert len(text.splitlines()) <= 120
    assert text.index("make simulate") < text.index("```python")


def test_the_guides_are_all_in_the_index() -> None:
    """Every guide is listed in the guides' index (its table of contents and links)."""
    index = (ROOT / "docs" / "guides" / "index.md").read_text()
    for page in (ROOT / "docs" / "guides").glob("*.md"):
        if page.stem != "index":
            assert f"\n{page.stem}\n" in index and f"]({page.name})" in index, page.name


def test_the_controller_guide_shows_the_example_as_it_is() -> None:
    """The guide's law is the shipped example's code, from its first import on (the
    example is what tests/test_extending.py runs on the simulated device and the bus)."""
    example = (ROOT / "examples" / "controllers" / "critical_pd.py").read_text()
    shown = [c for lang, c in blocks(ROOT / "docs" / "extending" / "controller.md")
             if lang == "python"][0]
    assert shown == example[example.index("import numpy as np"):]
