"""Benchmark: the operator interface -- how long an E-stop clicked in the browser takes to
reach the drives' command, and whether a browser watching the Live page slows the loop.

Run: ``python benchmarks/bench_hmi.py [sessions] [seconds]`` (default 8 sessions, 20 s).
Needs Debian's chromium and chromium-driver (``make test`` installs them as root).

What is timed, end to end on loopback: ``exoleg hmi`` (sim backend) serves the page to a
real headless Chromium; per session the page starts a session armed at the start, walks,
and the E-stop button is pressed. Each figure on one clock:

* on the page's clock (``window.estopTrace``): from the press (the event's time) to the
  server's answer, which it sends once the E-stop is queued for the loop;
* on the server's: from the request's arrival to the tick at which the controller applied
  the E-stop, after the drives' command (zero torque) was written (``control.log``:
  ``after_request_ms``);
* on the system's wall clock, which the page (``Date.now()``) and the server
  (``time.time()``) both read on this one machine: from the press (the page's wall clock
  at its handler less the time since the event on its monotonic clock) to the tick that
  wrote the drives' command (``control.log``: ``after_click_ms``). This is the figure
  judged; 1 ms is ``Date.now()``'s resolution. (The page's ``performance.timeOrigin +
  event.timeStamp``, used before, is a monotonic clock that drifted from the wall clock by
  about 20 ms a session here: it is no longer used.)

The first two parts' sum bounds the press to the drives' command from above (the answer
comes after the request arrived; it includes the answer's way back to the page), printed
beside it. Goal (issue 36): <= 50 ms at max over 8 sessions.

And how long the operator waits from Start to the device standing on the page: a
session's process started afresh loads the loop first; the console forks the sessions after
the first from a server of processes that has loaded it once
(:class:`exoleg.hmi.processes.SessionProcesses`).

Then the loop's lateness with the Live page open in Chromium (drawing at the browser's
frame rate from the 50 Hz stream) against the same session with no interface at all
(``exoleg run``), same duration, same machine, same run: the loop runs in its own process
and the web server keeps off its CPU, so the two should not differ beyond this VM's noise.
"""

from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path

import httpx
import numpy as np

from exoleg.hmi.testing import browser_missing, chromium, served_hmi, wait_until
from exoleg.runtime.session import run, summarize

SESSIONS = int(sys.argv[1]) if len(sys.argv) > 1 else 8
SECONDS = float(sys.argv[2]) if len(sys.argv) > 2 else 20.0


def one_session(d, url: str, walk_for: float, auth: dict) -> dict:  # type: ignore[no-untyped-def]
    """Start (armed), walk for ``walk_for`` s on the Live page, E-stop by the button;
    the applied E-stop's log entry and the session's folder."""
    mode = lambda: d.find_element("id", "ctl-mode").get_attribute("textContent")  # noqa: E731
    d.find_element("id", "nav-control").click()
    if not d.find_element("id", "arm-start").is_selected():
        d.find_element("id", "arm-start").click()
    t0 = time.perf_counter()
    d.find_element("id", "start").click()
    wait_until("standing", lambda: mode() == "STANDING", 60, every=0.01)
    started = time.perf_counter() - t0
    d.find_element("id", "cmd-walk").click()
    wait_until("walking", lambda: mode() == "WALKING")
    d.find_element("id", "nav-live").click()
    time.sleep(walk_for)
    d.find_element("id", "estop").click()
    entry = wait_until("the E-stop applied", lambda: [
        a for a in httpx.get(f"{url}/api/log", headers=auth).json()
        if a["source"] == "loop" and a["command"] == "estop"])[0]
    trace = wait_until("the page's answer", lambda: (
        t := d.execute_script("return window.estopTrace")) and "answered_ms" in t and t)
    entry["page_ms"] = trace["handler_ms"] + trace["answered_ms"]
    d.find_element("id", "nav-control").click()
    d.find_element("id", "end").click()
    wait_until("the session's end", lambda: httpx.get(f"{url}/api/state").json()
               .get("running") in ("ended", "none"))
    time.sleep(0.5)
    return {**entry, "start_s": started}


def main() -> None:
    missing = browser_missing()
    if missing:
        sys.exit(f"bench_hmi: no headless browser: {missing}")
    with tempfile.TemporaryDirectory() as tmp, served_hmi(Path(tmp) / "s") as hmi:
        d = chromium()
        try:
            d.get(hmi.page)
            d.find_element("id", "nav-control").click()
            d.find_element("id", "take").click()
            wait_until("control", lambda: "hold control" in
                       d.find_element("id", "hdr-operator").text)
            auth = {"Authorization": f"Bearer {hmi.token}"}
            entries = [one_session(d, hmi.url, SECONDS if k == 0 else 1.0, auth)
                       for k in range(SESSIONS)]
        finally:
            d.quit()
        page = np.array([e["page_ms"] for e in entries])
        requests = np.array([e["after_request_ms"] for e in entries])
        clicks = np.array([e["after_click_ms"] for e in entries])
        print(f"E-stop, press in Chromium -> drives' command written, {SESSIONS} sessions "
              "(goal: the wall clock's <= 50 ms at max):")
        for name, x in (("press -> server's answer (page)", page),
                        ("request -> drives (server)", requests),
                        ("press -> drives, bound (sum)", page + requests),
                        ("press -> drives (wall clock)", clicks)):
            print(f"  {name:<33} p50 {np.median(x):7.2f} ms   max {x.max():7.2f} ms")
        starts = np.array([e["start_s"] for e in entries])
        print(f"Start clicked -> the page showing the device standing (armed at the start): "
              f"the first session {starts[0]:.2f} s (its own process started afresh); the "
              f"next {SESSIONS - 1}, forked from the server of processes the first started, "
              f"p50 {np.median(starts[1:]):.2f} s, max {starts[1:].max():.2f} s")
        first = min(Path(tmp, "s").glob("2*"), key=lambda p: p.name)
        watched = summarize(first / "session.log")
    with tempfile.TemporaryDirectory() as tmp:
        _, path = run("sim", watched["duration_s"], tmp, arm=True, walk_after=1.0)
        alone = summarize(path)
    print(f"\nloop lateness, {watched['duration_s']:.1f} s session (sim, 1 kHz):")
    print(f"  {'':<36} {'p50 us':>8} {'p99 us':>8} {'max us':>9} {'missed':>7}")
    for name, s in (("Live page open in Chromium", watched), ("no interface (exoleg run)", alone)):
        print(f"  {name:<36} {s['late_p50_us']:8.2f} {s['late_p99_us']:8.2f} "
              f"{s['late_max_us']:9.1f} {s['missed_deadlines']:7d}")


if __name__ == "__main__":
    main()
