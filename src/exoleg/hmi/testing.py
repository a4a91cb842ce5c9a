"""Driving the operator interface from a program, as the tests and the benchmark do:
``exoleg hmi`` started as a user starts it, and a real headless Chromium (Debian's
``chromium`` and ``chromium-driver``, through Selenium) looking at it."""

from __future__ import annotations

import os
import re
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

#: Chromium's flags for a closed network (no background connections to look up)
CHROMIUM_FLAGS = ("--headless=new", "--no-sandbox", "--disable-gpu", "--disable-quic",
                  "--no-first-run", "--disable-background-networking",
                  "--disable-component-update", "--disable-sync",
                  "--disable-dev-shm-usage")


def browser_missing() -> str:
    """'' when a headless browser can be driven here; else what is missing."""
    try:
        import selenium  # noqa: F401
    except ImportError:
        return "selenium is not installed (pip install exoleg[dev])"
    for exe in ("chromium", "chromedriver"):
        if shutil.which(exe) is None:
            return (f"{exe} is not installed (Debian packages chromium and chromium-driver; "
                    "`make test` installs them where it may)")
    return ""


def chromium(width: int = 1400, height: int = 1000) -> Any:
    """A headless Chromium driven by Selenium, with the system's driver (nothing
    downloaded)."""
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    options = webdriver.ChromeOptions()
    options.binary_location = str(shutil.which("chromium"))
    for flag in CHROMIUM_FLAGS + (f"--window-size={width},{height}",):
        options.add_argument(flag)
    return webdriver.Chrome(service=Service(str(shutil.which("chromedriver"))),
                            options=options)


def wait_until(what: str, check: Callable[[], Any], timeout: float = 30.0,
               every: float = 0.05, seen: Callable[[], Any] | None = None) -> Any:
    """``check()``'s first truthy value (an exception counts as not yet: a page still
    loading, a server not yet up); an AssertionError naming ``what`` after ``timeout`` s,
    with what ``seen()`` then gives (what the page showed instead) when given."""
    deadline = time.time() + timeout
    last: Any = None
    while time.time() < deadline:
        try:
            last = check()
        except Exception as e:
            last = e
        if last and not isinstance(last, Exception):
            return last
        time.sleep(every)
    try:
        shown = f" (seen: {seen()!r})" if seen else ""
    except Exception as e:
        shown = f" (seen: {e!r})"
    raise AssertionError(f"{what}: still {last!r} after {timeout:g} s{shown}")


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


@dataclass
class Served:
    url: str
    token: str
    sessions: Path
    process: subprocess.Popen[Any]

    @property
    def page(self) -> str:
        """The page's address with the token, as ``exoleg hmi`` prints it."""
        return f"{self.url}/#token={self.token}"

    def start_session(self, duration: float, operator: str = "ann"
                      ) -> tuple[dict[str, str], Any]:
        """Control taken as ``operator`` and a session started, armed, for ``duration``
        s, through the control API: (the operator's headers, the start's response)."""
        import httpx

        base = f"{self.url}/api"
        auth = {"Authorization": f"Bearer {self.token}"}
        op = {**auth, "X-Operator": httpx.post(f"{base}/operator", json={"name": operator},
                                               headers=auth).json()["operator"]}
        return op, httpx.post(f"{base}/session/start",
                              json={"duration": duration, "arm": True}, headers=op)


@contextmanager
def served_hmi(sessions: Path, *args: str) -> Iterator[Served]:
    """``exoleg hmi --sessions DIR --port <free>`` in a subprocess until the block ends
    (then Ctrl-C, as a user stops it)."""
    port = free_port()
    exe = Path(sys.executable).with_name("exoleg")
    cmd = [str(exe) if exe.exists() else "exoleg", "hmi", "--sessions", str(sessions),
           "--port", str(port), *args]
    out = tempfile.TemporaryFile("w+")  # what it prints (read, never left to fill a pipe)
    proc = subprocess.Popen(cmd, stdout=out, stderr=subprocess.STDOUT, text=True,
                            env={**os.environ, "PYTHONUNBUFFERED": "1"})
    try:
        deadline = time.time() + 60
        said = ""
        while time.time() < deadline:
            out.seek(0)
            said = out.read()
            m = re.search(r"token \(for every control action\): (\S+)", said)
            if m:
                break
            if proc.poll() is not None:
                raise RuntimeError(f"exoleg hmi ended: {said}")
            time.sleep(0.05)
        else:
            raise RuntimeError(f"exoleg hmi did not start: {said}")
        yield Served(f"http://127.0.0.1:{port}", m.group(1), sessions, proc)
    finally:
        if proc.poll() is None:
            proc.send_signal(signal.SIGINT)
            try:
                proc.wait(timeout=20)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()
        out.close()
