"""The console a clinic can trust (issue 36), tried as an operator and a safety reviewer
would, in Debian's headless Chromium against ``exoleg hmi`` on the simulated device:

* the E-STOP stops a walking device with each confirmation dialog open, at a desk's, a
  laptop's and a phone's size, by click and by its key; Esc in a dialog cancels it;
* the device is never armed with nobody in control: control given up while walking is a
  controlled stop, then disarm; a tab closed while standing armed disarms it;
* every way a session ends leaves its reason on every open page until acknowledged;
* an E-stop clicked while the server is frozen says at once that it did not reach the
  device, and goes through once the server answers;
* a burst of 2,000 requests during a walk neither ends the session nor keeps an E-stop
  from being applied;
* one real device, one process: a second console or run on the same interface is
  refused before it touches the bus.

References: the supervisor's rules (arming, E-stop latched, DISARMED / STANDING /
WALKING), the session's own records (``run.json``'s ``stopped_by``, ``control.log``), and
the operator rules of :mod:`exoleg.runtime.operator`."""

from __future__ import annotations

import asyncio
import contextlib
import json
import os
import signal
import subprocess
import threading
import time
from collections.abc import Awaitable, Callable
from pathlib import Path
from typing import Any

import pytest

pytest.importorskip("starlette", reason="starlette (exoleg[api])")
httpx = pytest.importorskip("httpx", reason="httpx (exoleg[dev])")

from conftest import EXOLEG, SIM_OVERRUN, Taken, http  # noqa: E402
from exoleg.hmi.testing import browser_missing, chromium, served_hmi, wait_until  # noqa: E402
from exoleg.runtime.link import LINK_TIMEOUT_S  # noqa: E402
from exoleg.runtime.operator import LEASE_S  # noqa: E402

missing = browser_missing()
browser = pytest.mark.skipif(bool(missing), reason=f"no headless browser: {missing}")
SHOTS = Path(__file__).resolve().parents[1] / "build" / "screenshots"
#: the sizes the issue names: a desk, a laptop, a phone (CSS px)
SIZES = ((1400, 1000), (1024, 768), (390, 844))
#: the E-stop on screen and on top: its centre inside the viewport, and the element there
#: the button itself (not a dialog, a backdrop or a banner)
ESTOP_ON_TOP_JS = """
const b = document.getElementById("estop"), r = b.getBoundingClientRect();
const x = r.left + r.width / 2, y = r.top + r.height / 2;
const top = document.elementFromPoint(x, y);
return x > 0 && y > 0 && x < innerWidth && y < innerHeight && (top === b || b.contains(top));
"""


class Console:
    """``exoleg hmi`` driven through its API as the operator's page drives it."""

    def __init__(self, served: Any) -> None:
        self.s = served
        self.api = f"{served.url}/api"
        self.auth = {"Authorization": f"Bearer {served.token}"}
        self.op: dict[str, str] = {}

    def keep(self) -> None:
        """Hold control (again, after a lapse), as the page does every second."""
        if not (self.op and http.get(f"{self.api}/operator", headers=self.op).json()["you"]):
            self.take()

    def take(self, name: str = "tess") -> None:
        r = http.post(f"{self.api}/operator", json={"name": name}, headers=self.auth)
        assert r.status_code == 200, r.text
        self.op = {**self.auth, "X-Operator": r.json()["operator"]}

    def release(self) -> None:
        """Give control back (the next test takes it), if this holds it."""
        if self.op:
            http.delete(f"{self.api}/operator", headers=self.op)
            self.op = {}

    def state(self) -> dict[str, Any]:
        """The state, as the operator's page reads it: its hold kept alive on the way
        (the page asks every second; nobody in control of an armed device stops it)."""
        if self.op:
            http.get(f"{self.api}/operator", headers=self.op, timeout=5)
        return dict(http.get(f"{self.api}/state", timeout=5).json())

    @contextlib.contextmanager
    def holding(self) -> Any:
        """Hold control every second on a thread of its own while the block runs, as the
        operator's page does whatever else it is busy with (a test's own polling can be
        held up for seconds on two busy CPUs). Yields the longest gap between two holds
        the server answered, s, in a one-element list (read it after the block)."""
        gap = [0.0]
        stop = threading.Event()

        def hold() -> None:
            last = time.monotonic()
            while not stop.wait(1.0):
                with contextlib.suppress(httpx.HTTPError):
                    http.get(f"{self.api}/operator", headers=self.op, timeout=5)
                    now = time.monotonic()
                    gap[0], last = max(gap[0], now - last), now

        thread = threading.Thread(target=hold, name="hold", daemon=True)
        thread.start()
        try:
            yield gap
        finally:
            stop.set()
            thread.join()

    def mode(self) -> str:
        from exoleg.tick import Mode

        s = self.state()
        return Mode(s["mode"]).name if s.get("running") == "running" else s.get("running", "")

    def wait_mode(self, mode: str, timeout: float = 30.0) -> None:
        wait_until(f"mode {mode}", lambda: self.mode() == mode, timeout)

    def command(self, name: str) -> dict[str, Any]:
        self.keep()
        r = http.post(f"{self.api}/command", json={"command": name}, headers=self.op,
                      timeout=5)
        assert r.status_code == 200, r.text
        return dict(r.json())

    def start(self, duration: float = 120.0, arm: bool = True) -> Path:
        self.keep()
        if self.state().get("running") in ("running", "starting"):  # a test that failed
            live = http.get(f"{self.s.url}/api/info").json()["session"]
            self.end(self.s.sessions / live)
        r = http.post(f"{self.s.url}/api/session/start", headers=self.op, timeout=30,
                      json={"duration": duration, "arm": arm})
        assert r.status_code == 200, r.text
        folder = self.s.sessions / r.json()["session"]
        wait_until("the loop ticking", lambda: self.state().get("running") == "running", 60)
        return folder

    def end(self, folder: Path) -> dict[str, Any]:
        """End the session if it runs; its run.json once written."""
        if self.state().get("running") in ("running", "starting"):
            self.keep()
            http.post(f"{self.s.url}/api/session/end", headers=self.op, timeout=10)
        return ended(folder, self)

    def session_pid(self) -> int:
        """The session's own process."""
        from conftest import session_processes

        (pid,) = session_processes(self.s.process.pid)
        return pid


def in_control(c: Console, d: Any) -> Any:
    """Browser ``d`` opens the operator's page, takes control there, and ``c`` acts as
    that page (its operator id); returns ``d``."""
    d.get(c.s.page)
    d.find_element("id", "nav-control").click()
    d.find_element("id", "take").click()
    wait_until("control", lambda: "hold control" in text(d, "hdr-operator"))
    c.op = {**c.auth, "X-Operator": d.execute_script("return S.operator")}
    return d


def ended(folder: Path, c: Console, timeout: float = 30.0) -> dict[str, Any]:
    run = json.loads(wait_until("run.json", lambda: (folder / "run.json").exists() and (
        folder / "run.json").read_text(), timeout))
    wait_until("the session detached", lambda: c.state()["running"] == "none", timeout)
    return dict(run)


def actions(folder: Path) -> list[dict[str, Any]]:
    return [json.loads(x) for x in (folder / "control.log").read_text().splitlines()]


def shot(driver: Any, name: str) -> None:
    SHOTS.mkdir(parents=True, exist_ok=True)
    driver.save_screenshot(str(SHOTS / f"{name}.png"))


def text(driver: Any, id_: str) -> str:
    return str(driver.find_element("id", id_).text)


@pytest.fixture(scope="module")
def console(tmp_path_factory: pytest.TempPathFactory) -> Any:
    with served_hmi(tmp_path_factory.mktemp("safety") / "sessions") as served:
        yield served


@browser
def test_the_estop_stops_a_walking_device_with_every_dialog_open(console: Any) -> None:
    # Issue 36: the dialog's backdrop took the E-STOP's click and the device walked on;
    # Esc, the key that cancels a dialog, was the E-stop inside it.
    c = Console(console)
    d = chromium(*SIZES[0])
    try:
        in_control(c, d)
        for w, h in SIZES:
            d.set_window_size(w, h)
            for dialog, key in (("end", False), ("disarm", True)):
                folder = c.start()
                c.wait_mode("STANDING")
                if dialog == "end":
                    c.command("walk")
                    c.wait_mode("WALKING")
                button = d.find_element("id", {"end": "end", "disarm": "cmd-disarm"}[dialog])
                d.execute_script("arguments[0].scrollIntoView({block: 'center'})", button)
                button.click()
                wait_until("the question", lambda: d.find_element("id", "confirm")
                           .is_displayed())
                if dialog == "end":
                    # Esc cancels the question, and only that
                    d.switch_to.active_element.send_keys("\ue00c")
                    wait_until("cancelled", lambda: not d.find_element("id", "confirm")
                               .is_displayed())
                    time.sleep(0.3)
                    assert c.mode() == "WALKING"
                    button.click()
                    wait_until("asked again", lambda: d.find_element("id", "confirm")
                               .is_displayed())
                else:  # the device walks with the Disarm question open
                    c.command("walk")
                    c.wait_mode("WALKING")
                assert d.execute_script(ESTOP_ON_TOP_JS), (w, h, dialog)
                shot(d, f"estop-over-{dialog}-{w}x{h}")
                if key:  # F2, the E-stop's key, shown on it
                    assert "F2" in text(d, "estop")
                    d.switch_to.active_element.send_keys("\ue032")
                else:
                    d.find_element("id", "estop").click()
                c.wait_mode("FAULT", timeout=5)
                # the question asked before the E-stop no longer stands
                assert not d.find_element("id", "confirm").is_displayed()
                run = c.end(folder)
                assert "after an E-stop" in run["stopped_by"]
    finally:
        c.release()
        d.quit()


def test_never_armed_with_nobody_in_control(console: Any) -> None:
    # Issue 36: "Give up control" while WALKING was accepted without a word and the
    # device walked on with nobody in control; a tab closed while STANDING left it armed.
    c = Console(console)
    c.take("tess")
    folder = c.start()
    c.command("walk")
    c.wait_mode("WALKING")
    r = http.delete(f"{c.api}/operator", headers=c.op)
    assert r.status_code == 200
    assert r.json()["alarm"]["text"].startswith(
        "nobody in control: tess gave up control while WALKING: controlled stop to "
        "standing, then disarm")
    # stood, then disarmed: the loop applied both, in that order (its control log; the
    # simulated leg, with no muscles of its own, may fold past its range a few tenths of
    # a second after the disarm, quicker than a poll may catch DISARMED)
    applied = lambda: [a["command"] for a in actions(folder)  # noqa: E731
                       if a["source"] == "loop" and a["accepted"]]
    wait_until("stood, then disarmed", lambda: applied()[-2:] == ["stand", "disarm"], 15)
    assert c.state()["alarm"]["text"] == r.json()["alarm"]["text"]  # on every page
    alarm = [a for a in actions(folder) if a["command"] == "alarm"]
    assert alarm and alarm[0]["operator"] == "tess"
    wait_until("at rest", lambda: c.mode() in ("DISARMED", "FAULT"), 5)
    c.take("tess")
    c.end(folder)
    # the operator's note on the ended session: in the records and its own control log
    r = http.post(f"{console.url}/api/session/note", headers=c.op,
                  json={"note": "walked well; stopped for a shoe"})
    assert r.status_code == 200 and r.json()["session"] == folder.name
    note = actions(folder)[-1]
    assert (note["command"], note["why"], note["operator"]) == (
        "note", "walked well; stopped for a shoe", "tess")
    row = next(s for s in http.get(f"{console.url}/api/sessions", headers=c.auth).json()
               if s["name"] == folder.name)
    assert (row["operator"], row["note"]) == ("tess", "walked well; stopped for a shoe")
    c.release()


@browser
def test_a_tab_closed_while_standing_armed_disarms_the_device(console: Any) -> None:
    c = Console(console)
    tab, watcher = chromium(1024, 768), chromium(390, 844)
    try:
        in_control(c, tab)
        watcher.get(console.url + "/#live")
        folder = c.start()
        c.wait_mode("STANDING")
        tab.get("about:blank")  # the operator's tab is gone
        gone = time.time()
        alarm = wait_until("the alarm on the other page", lambda: watcher.find_element(
            "id", "alarm").is_displayed() and text(watcher, "alarm"), LEASE_S + 5)
        assert "nobody in control: link lost: operator's hold on control lapsed" in alarm
        assert "while STANDING: disarm" in alarm
        wait_until("disarmed", lambda: any(
            a["command"] == "disarm" and a["source"] == "loop" and a["accepted"]
            for a in actions(folder)), 5)
        # the lease from the page's last word (<= 1 s before it went), the stand and the
        # disarm (tens of ms); the rest is this suite's load on 2 CPUs
        assert time.time() - gone < LEASE_S + 3.0
        shot(watcher, "nobody-in-control")
        c.take()
        c.end(folder)
    finally:
        c.release()
        tab.quit()
        watcher.quit()


def _freeze(pid: int, seconds: float) -> None:
    os.kill(pid, signal.SIGSTOP)
    try:
        time.sleep(seconds)
    finally:
        os.kill(pid, signal.SIGCONT)


@browser
def test_every_stop_is_explained_on_every_page(console: Any) -> None:
    # Issue 36: a session that ended by itself left every page saying "no session": no
    # reason, the last frame still drawn, a mode the loop was no longer in. Five causes;
    # each reason (the session's own run.json) on both open pages until acknowledged.
    c = Console(console)
    desk, phone = chromium(1400, 1000), chromium(390, 844)
    try:
        desk.get(console.page)
        phone.get(console.url + "/#live")  # a person watching, no token
        c.take()

        def on_every_page(folder: Path, run: dict[str, Any], cause: str) -> None:
            # until the page's next poll it may still show the session before's ending
            # (kept until acknowledged): wait for this one's, then hold it to run.json
            def this_end(page: Any) -> str | bool:
                said = text(page, "ended-banner")
                return page.find_element("id", "ended-banner").is_displayed() and (
                    f"Session {folder.name} ended" in said) and said

            for page in (desk, phone):
                said = wait_until(f"{cause}: the reason on the page", lambda p=page: this_end(p),
                                  10, seen=lambda p=page: text(p, "ended-banner"))
                assert run["stopped_by"] in said
                assert text(page, "hdr-mode") == "-" and text(page, "t-session") == "-"
            shot(phone, f"ended-{cause}")

        # 1. the end of its duration
        folder = c.start(duration=4.0)
        run = ended(folder, c)
        assert run["stopped_by"] == "duration"
        on_every_page(folder, run, "duration")
        # acknowledged on one page: gone there, still on the other
        desk.find_element("id", "ended-ack").click()
        assert not desk.find_element("id", "ended-banner").is_displayed()
        assert phone.find_element("id", "ended-banner").is_displayed()

        # 2. a loop overrun: the session's process stalled past the overrun limit (the
        # suite's for simulated devices, conftest)
        folder = c.start()
        _freeze(c.session_pid(), SIM_OVERRUN + 0.35)
        run = ended(folder, c)
        assert run["stopped_by"].startswith("loop overrun")
        on_every_page(folder, run, "overrun")

        # 3. a lost link: the server frozen past the heartbeat's timeout
        folder = c.start()
        c.wait_mode("STANDING")
        _freeze(console.process.pid, LINK_TIMEOUT_S + 0.8)
        run = ended(folder, c)
        assert run["stopped_by"].startswith("link lost")
        on_every_page(folder, run, "link-lost")

        # 4. an E-stop that the server does not answer (its request held in the browser,
        # through the DevTools protocol: a server frozen for longer would be case 3): the
        # page says at once that it did not reach the device, and sends it again until
        # it does. The device armed and standing (the E-stop from walking, with every
        # dialog open: test_the_estop_stops_a_walking_device_with_every_dialog_open; the
        # passive paper leg's walk faulted at its start once in six runs of the suite on
        # two busy cores, which is not what this case tests)
        folder = c.start()
        c.wait_mode("STANDING")
        desk.execute_cdp_cmd("Fetch.enable", {"patterns": [{"urlPattern": "*/api/estop"}]})
        # the operator holds control meanwhile, every second on a thread of its own (a
        # hold let lapse disarms the standing device: seen once when this test's own
        # polling held it, 5 s gone by here on two busy CPUs)
        with c.holding() as gap:
            try:
                desk.find_element("id", "estop").click()
                said = wait_until("no answer said", lambda: "DID NOT REACH" in text(
                    desk, "message") and text(desk, "message"), 10)
                assert "Use the hardware E-stop now" in said
                # within the page's wait for an answer (ESTOP_WAIT_MS, 300 ms), by its clock
                assert 300 <= desk.execute_script("return window.estopUnreachableMs") < 1000
                s = c.state()
                # it did not reach it (a hold the server answered late is not this case)
                assert c.mode() == "STANDING" or gap[0] >= LEASE_S, (
                    s["fault_text"], f"longest gap between holds {gap[0]:.1f} s",
                    f"server's longest stall {s.get('server_stall_max_s')} s")
            finally:
                desk.execute_cdp_cmd("Fetch.disable", {})
        wait_until("reached once answered", lambda: "E-STOP reached the device" in text(
            desk, "message"), 15)
        assert "(sent " in text(desk, "message")  # again, until the server answered
        c.wait_mode("FAULT", timeout=5)
        run = c.end(folder)
        assert "after an E-stop" in run["stopped_by"]
        on_every_page(folder, run, "estop")

        # 5. a safety fault: walking transparent, the device leaves the simulated leg (the
        # paper's, no child acting in it) to fall past its range of motion (standing, the
        # device holds it in every support mode)
        folder = c.start()
        c.command("transparent")
        c.command("walk")
        c.wait_mode("FAULT", timeout=20)
        run = c.end(folder)
        assert "(after a fault: HARD_LIMIT" in run["stopped_by"], run
        on_every_page(folder, run, "fault")
        assert "Fault: " in text(phone, "ended-banner")
    finally:
        c.release()
        desk.quit()
        phone.quit()


@pytest.fixture
def own_console(tmp_path: Path) -> Any:
    """A console of the test's own: its event loop's longest stall since it started is
    then the test's. (The file's console is frozen for LINK_TIMEOUT_S + 0.8 s on purpose
    by test_every_stop_is_explained_on_every_page: the 1.8 s "stall" two CI runs of the
    burst reported was that freeze.)"""
    with served_hmi(tmp_path / "sessions") as served:
        yield served


def test_a_request_burst_during_a_walk(own_console: Any) -> None:
    # Issue 36: two bursts of token-free requests ended a walking session through "link
    # lost" (the heartbeat beat on the server's event loop, which the burst held up).
    from exoleg.runtime.control_api import EVENT_LOOP_STALL_S

    console = own_console
    c = Console(console)
    c.take()
    bad = {"Authorization": "Bearer wrong"}

    async def burst(resent: list[int]) -> list[tuple[int, Any]]:
        limits = httpx.Limits(max_connections=50)  # within the listen backlog (64)
        async with httpx.AsyncClient(base_url=console.url, limits=limits,
                                     timeout=httpx.Timeout(60, pool=None)) as client:
            # 50 at a time (httpx's own pool queue, given 1,500 at once, sent its first
            # request 11.6 s late)
            at_once = asyncio.Semaphore(50)

            async def one(i: int) -> tuple[int, Any]:
                async with at_once:
                    try:
                        return await ask(i)
                    except (httpx.ReadError, httpx.RemoteProtocolError):
                        # a kept-alive connection the server closed as the request went
                        # out (the kernel answers it with a reset): a browser sends such a
                        # request again on a new connection, and so does the test
                        resent.append(i)
                        return await ask(i)

            async def ask(i: int) -> tuple[int, Any]:
                if i == 1500:  # the E-stop, in the thick of it
                    r = await client.post("/api/estop", json={})
                    return r.status_code, r.json()
                kind = i % 5
                if kind == 0:  # the operator's page watching the state
                    r = await client.get("/api/state", headers=c.op)
                elif kind == 1:
                    r = await client.post("/api/command", json={"command": "stand"})
                elif kind == 2:
                    r = await client.post("/api/command", json={"command": "disarm"},
                                          headers=bad)
                elif kind == 3:
                    r = await client.get("/api/info", headers=c.auth)
                else:
                    r = await client.post("/api/gains", json={"support": 0.1},
                                          headers=c.auth)  # the token, not control
                return r.status_code, r.json()

            async def the_page(done: asyncio.Event) -> None:
                """The operator's page keeping its hold as hmi.js does: its own
                connection, GET /api/operator every second. (Sent inside the burst's
                queue, every 50th request, it waited behind the burst's own requests in
                this process: a fresh-clone CI run's burst took 30.5 s, the hold lapsed,
                and the test measured its own queue, not the server.)"""
                async with httpx.AsyncClient(base_url=console.url,
                                             timeout=httpx.Timeout(60)) as page:
                    while not done.is_set():
                        await page.get("/api/operator", headers=c.op)
                        with contextlib.suppress(TimeoutError):
                            await asyncio.wait_for(done.wait(), 1.0)

            done = asyncio.Event()
            page = asyncio.create_task(the_page(done))
            # 1,500 while walking, then the E-stop with the last 499 under way
            head = await asyncio.gather(*(one(i) for i in range(1500)))
            tail = [asyncio.create_task(one(i)) for i in range(1501, 2000)]
            await asyncio.sleep(0.05)
            stop = await one(1500)
            answers = [*head, stop, *await asyncio.gather(*tail)]
            done.set()
            await page
            return answers

    def walk_through_a_burst() -> tuple[Path, list[tuple[int, Any]], list[int], float,
                                        Taken]:
        """A walking session through the burst: its folder, the answers, the requests
        sent again, the event loop's longest stall (s) and what the host and other
        processes' real-time threads took meanwhile."""
        folder = c.start()
        c.command("walk")
        c.wait_mode("WALKING")
        resent: list[int] = []
        began = time.time()
        with Taken(console.process.pid) as taken:
            answers = asyncio.run(burst(resent))
        stall = c.state()["server_stall_max_s"]
        print(f"2,000 requests in {time.time() - began:.1f} s; the event loop's longest "
              f"stall so far {stall:.3f} s; {len(resent)} sent again after a connection "
              f"reset; {taken}")
        return folder, answers, resent, stall, taken

    def walked(answers: list[tuple[int, Any]]) -> list[int]:
        """The modes every state the burst read before the E-stop said."""
        return [a["mode"] for i, (_, a) in enumerate(answers) if i < 1500 and "mode" in a]

    folder, answers, resent, stall, taken = walk_through_a_burst()
    if set(walked(answers)) != {2} and taken.worth(LINK_TIMEOUT_S):
        # the virtual machine's host, or the real-time threads of the suite's other files
        # (a CANopen identification's, 1.2 CPUs), took the CPUs for as long as the link
        # may stay silent (fresh-clone CI runs: the burst 23.7 s against 8.6-14 s, the
        # walk stopped; the console's event loop and heartbeat stopped 1.244 s with the
        # host's steal at 0.23 s): the session was right to stop, and this test's
        # question is not asked; once more
        c.end(folder)
        folder, answers, resent, stall, taken = walk_through_a_burst()
    assert stall < EVENT_LOOP_STALL_S  # a busy server, not a hung one
    # connections reset: 0 in 5 runs here (2 of them beside two busy cores), 1 in one CI
    # run; a server that dropped connections under load would reset many
    assert len(resent) <= 10, resent
    # walking throughout until the E-stop: every state the burst read before it (why it
    # stopped, when it did: the loop's, the session's and the console's own lines of
    # control.log -- the burst's thousand refusals left out --, the stall and the steal)
    modes = walked(answers)
    own = [f"{a['source']} {a['command']} {a['accepted']} {a.get('why', '')}"
           for a in actions(folder) if a["source"] in ("loop", "session", "hmi")]
    assert modes and set(modes) == {2}, (set(modes), f"stall {stall:.3f} s, {taken}",
                                         own[-6:])
    assert len(answers) == 2000 and answers[1500] == (200, {"queued": "estop"}), answers[1500]
    assert {s for s, _ in answers} <= {200, 401, 409}
    # the session runs on: no lost link, no overrun, no alarm; the E-stop applied in it
    assert c.state()["running"] == "running"
    assert not any(a["command"] == "alarm" for a in actions(folder))
    c.wait_mode("FAULT", timeout=5)
    log = actions(folder)
    assert any(a["source"] == "loop" and a["command"] == "estop" for a in log)
    run = c.end(folder)
    assert run["stopped_by"].startswith("the operator ended the session"), run
    c.release()


def _watched(tmp_path: Path, scene: Callable[[Any], Awaitable[None]]) -> Any:
    """A console's watch (:meth:`ControlAPI.watch` on an event loop) over a new session's
    link while ``scene(link)`` runs beside it; the console."""
    from exoleg.runtime.control_api import ControlAPI
    from exoleg.runtime.link import LoopLink

    api, link = ControlAPI(folder=tmp_path), LoopLink.new()
    api.attach(link, tmp_path)

    async def server() -> None:
        watch = asyncio.create_task(api.watch())
        await asyncio.sleep(0.05)
        await scene(link)
        watch.cancel()

    asyncio.run(server())
    return api


def test_the_heartbeat_outlives_a_busy_server_not_a_hung_one(tmp_path: Path) -> None:
    # Issue 36: the heartbeat beat on the server's event loop, so a burst of requests
    # that held the event loop up for a second ended a walking session as a lost link.
    # Fault injection: the event loop held up (blocking work in it) for twice the link's
    # timeout -- the heartbeat goes on; held up past EVENT_LOOP_STALL_S -- a hung server,
    # the heartbeat stops and the link is lost (a dead or frozen process: at once).
    from exoleg.runtime.control_api import EVENT_LOOP_STALL_S

    seen: dict[str, bool] = {}

    async def busy_then_hung(link: Any) -> None:
        time.sleep(2 * LINK_TIMEOUT_S)  # busy: the event loop does not turn for 2 s
        seen["busy"] = link.link_lost()
        await asyncio.sleep(0.05)
        time.sleep(EVENT_LOOP_STALL_S + LINK_TIMEOUT_S + 0.5)  # hung
        seen["hung"] = link.link_lost()

    api = _watched(tmp_path, busy_then_hung)
    assert seen == {"busy": False, "hung": True}
    assert api.stall_max_s >= 2 * LINK_TIMEOUT_S  # the busy stall, measured by the watch


def test_the_heartbeat_outlives_a_loop_frozen_mid_write(tmp_path: Path) -> None:
    # Found in a serial run of the browser tests: a session's process stopped by the OS
    # while it wrote the shared block (the overrun case of the test above froze it so)
    # left the block mid-write past the web side's retries (1000 copies: 60-100 ms); the
    # copy's error ended the heartbeat's thread, and from then on no session of that
    # console was beaten: one started later never saw its link lost when the server froze
    # (a link never beaten was not lost then), and the loop's answers went unlogged. Fault
    # injection: the block held mid-write until the watch's copy has given up (its
    # retries are counted, so their time grows with the machine's load: 0.2 s was not
    # enough once in CI), then released -- the heartbeat goes on, the failure said once.
    seen: dict[str, bool] = {}

    async def torn(link: Any) -> None:
        link.view["seq"] += 1.0  # odd: the loop is writing it
        deadline = time.monotonic() + 30.0
        while not (tmp_path / "control.log").exists() and time.monotonic() < deadline:
            await asyncio.sleep(0.05)
        await asyncio.sleep(0.2)  # the watch goes on failing meanwhile: said once
        link.view["seq"] += 1.0  # written
        await asyncio.sleep(2 * LINK_TIMEOUT_S)
        seen["lost"] = link.link_lost()

    _watched(tmp_path, torn)
    assert seen == {"lost": False}
    said = [a for a in actions(tmp_path) if a["command"] == "watch failed"]
    assert len(said) == 1 and "mid-write" in said[0]["why"], said


def test_one_real_device_one_process(tmp_path: Path) -> None:
    # Issue 36: two `exoleg hmi` could start sessions on the same device at once. A real
    # interface is held by the first process; the second, whatever its command, is
    # refused before it touches the bus, naming the holder. Simulated devices run side by
    # side (the other tests of this suite run several at once).
    env = {**os.environ, "EXOLEG_LOCK_DIR": str(tmp_path)}
    channel = f"exotest{os.getpid() % 10000}"
    bus = ["--backend", "canopen", "--interface", "socketcan", "--channel", channel]
    from exoleg.hmi.testing import free_port

    first = subprocess.Popen([EXOLEG, "hmi", *bus, "--sessions", str(tmp_path / "a"),
                              "--port", str(free_port())], stdout=subprocess.PIPE,
                             stderr=subprocess.STDOUT, text=True, env=env)
    try:
        line = wait_until("the first console up", lambda: first.stdout.readline(), 60)
        while "held by this interface alone" not in line:
            line = first.stdout.readline()
            assert line, "the first console ended"
        for cmd in (["hmi", *bus, "--sessions", str(tmp_path / "b"), "--port",
                     str(free_port())],
                    ["run", *bus, "--duration", "1", "--out", str(tmp_path / "r")]):
            r = subprocess.run([EXOLEG, *cmd], capture_output=True, text=True, env=env,
                               timeout=120)
            assert r.returncode == 2, (cmd, r.stdout, r.stderr)
            said = r.stdout + r.stderr
            assert (f"the device canopen:socketcan:{channel} is held by exoleg hmi "
                    f"(process {first.pid})") in said, said
            assert "Traceback" not in said
            assert not (tmp_path / "r" / "session.log").exists()
    finally:
        first.send_signal(signal.SIGINT)
        first.wait(timeout=30)
    # let go when it ended: the next may hold it
    from exoleg.runtime.device_lock import device_name, hold_device, let_go

    os.environ["EXOLEG_LOCK_DIR"] = str(tmp_path)
    try:
        fd = hold_device(device_name("canopen", "socketcan", channel), "this test")
        assert fd is not None
        let_go(fd)
    finally:
        del os.environ["EXOLEG_LOCK_DIR"]
