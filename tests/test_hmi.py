"""The operator interface in a real headless Chromium against ``exoleg hmi`` on the sim
backend: every page loads; a child is fitted and kept; the operator takes control,
starts a session, arms, walks, changes a gain (outside the bounds refused with the
reason); a second browser without control is refused, and its E-stop still stops the
device; the runtime's log shows the torque at zero from the E-stop's tick on; the
session is listed, plotted and exported. Screenshots of each page go to
``build/screenshots/``.

References: the supervisor's rules (arming, E-stop latched), the control API's contract,
the session log, and exoleg's own forward kinematics for the leg the page draws."""

from __future__ import annotations

import io
import json
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest

pytest.importorskip("starlette", reason="starlette (exoleg[api])")
httpx = pytest.importorskip("httpx", reason="httpx (exoleg[dev])")

from exoleg.hmi.testing import (  # noqa: E402
    browser_missing,
    chromium,
    served_hmi,
    wait_until,
)

missing = browser_missing()
pytestmark = pytest.mark.skipif(bool(missing), reason=f"no headless browser: {missing}")

SHOTS = Path(__file__).resolve().parents[1] / "build" / "screenshots"


def text(driver: Any, id_: str) -> str:
    return str(driver.find_element("id", id_).text)


def shot(driver: Any, name: str) -> None:
    SHOTS.mkdir(parents=True, exist_ok=True)
    driver.save_screenshot(str(SHOTS / f"{name}.png"))


def goto(driver: Any, page: str) -> None:
    driver.find_element("id", f"nav-{page}").click()
    wait_until(f"page {page}", lambda: driver.find_element("id", f"page-{page}").is_displayed())


def fill(driver: Any, id_: str, value: object) -> None:
    e = driver.find_element("id", id_)
    e.clear()
    e.send_keys(str(value))


@pytest.fixture(scope="module")
def hmi(tmp_path_factory: pytest.TempPathFactory) -> Any:
    with served_hmi(tmp_path_factory.mktemp("hmi") / "sessions") as served:
        yield served


@pytest.fixture(scope="module")
def operator(hmi: Any) -> Any:
    d = chromium(1400, 1350)  # the whole Live page in one screenshot
    d.get(hmi.page)
    yield d
    d.quit()


@pytest.fixture(scope="module")
def viewer(hmi: Any) -> Any:
    d = chromium()
    d.get(hmi.url + "/#live")  # no token: a person watching
    yield d
    d.quit()


def test_child_page_fits_and_keeps_the_child(hmi: Any, operator: Any) -> None:
    d = operator
    goto(d, "control")
    d.find_element("id", "take").click()
    wait_until("control taken", lambda: "you (operator) hold control" in text(d, "hdr-operator"))
    goto(d, "child")
    form = d.find_element("id", "child-form")
    for name, value in (("name", "Ada"), ("age", "10"), ("height", "138"), ("mass", "32")):
        field = form.find_element("name", name)
        field.clear()
        field.send_keys(value)
    d.find_element("id", "fit").click()
    verdict = wait_until("the fit's verdict", lambda: text(d, "verdict"), timeout=60)
    # the same child through exoleg's own fitting (exoleg.sizing.report.fit_report)
    from exoleg.sizing import Child
    from exoleg.sizing.report import fit_report

    rep = fit_report(Child(age=10, sex="female", height=1.38, mass=32, name="Ada"))
    assert verdict == rep.verdict
    page = text(d, "fit-result")
    assert f"upper (hip-knee) {rep.fit.upper * 100:.1f} cm" in page
    assert f"lower (knee-sole) {rep.fit.lower * 100:.1f} cm" in page
    wait_until("the child listed", lambda: "Ada: 10 y" in text(d, "children"))
    kept = json.loads((hmi.sessions / "children" / "Ada" / "fit.json").read_text())
    assert kept["verdict"] == rep.verdict and (hmi.sessions / "children" / "Ada" /
                                               "leg.toml").is_file()
    shot(d, "child")


def test_session_arm_walk_gains_estop_in_the_browser(hmi: Any, operator: Any,
                                                     viewer: Any) -> None:
    d = operator
    goto(d, "control")
    fill(d, "duration", 120)
    d.find_element("id", "start").click()
    wait_until("session running, disarmed", lambda: text(d, "ctl-mode") == "DISARMED",
             timeout=60)
    d.find_element("id", "cmd-arm").click()
    wait_until("standing", lambda: text(d, "ctl-mode") == "STANDING")
    d.find_element("id", "cmd-walk").click()
    wait_until("walking", lambda: text(d, "ctl-mode") == "WALKING")
    shot(d, "control")
    _server_keeps_off_the_loops_cpu(hmi.process.pid)

    # Live: read at >= 20 Hz (the stream is 50 Hz), the leg drawn with exoleg's kinematics
    goto(d, "live")
    time.sleep(2.5)
    rate = float(text(d, "rate").split()[0])
    assert rate >= 20.0, rate  # the floor for a person to read
    q, pts, lengths = d.execute_script(
        "const s = S.state, dv = S.info.device;"
        "return [s.q, legPoints(s.q, dv.lengths, dv.offsets), dv.lengths];")
    import exoleg

    ada = exoleg.load_leg(next((hmi.sessions).glob("*-Ada/leg.toml")))
    assert lengths == pytest.approx(list(ada.lengths), abs=1e-12)  # the fitted child's leg
    fk = ada.fk(np.array(q))
    for i, point in enumerate(("hip", "knee", "ankle", "toe")):
        assert pts[i] == pytest.approx(list(fk[point]), abs=1e-12)
    assert text(d, "phase") in ("swing", "loading", "foot flat", "push-off")
    shot(d, "live")

    # Gains: outside the bounds refused with the reason, inside accepted
    goto(d, "control")
    wait_until("gains shown", lambda: d.find_element("id", "g-kp_swing-2"))
    g = httpx.get(f"{hmi.url}/api/gains").json()
    kp = g["gains"]["kp_swing"][2]
    fill(d, "g-kp_swing-2", 3 * kp)
    d.find_element("id", "apply-gains").click()
    msg = wait_until("refusal", lambda: "refused" in text(d, "message") and text(d, "message"))
    assert f"kp_swing[2] = {3 * kp:g} is outside 0-{2 * kp:g}" in msg
    fill(d, "g-kp_swing-2", 1.5 * kp)
    fill(d, "g-support-0", 0.6)
    d.find_element("id", "apply-gains").click()
    wait_until("gains in force", lambda: httpx.get(f"{hmi.url}/api/gains").json()["gains"]
             ["support"] == [0.6])
    assert httpx.get(f"{hmi.url}/api/gains").json()["gains"]["kp_swing"][2] == \
        pytest.approx(1.5 * kp)

    # A second person: no token -> refused; with the token, control is held -> view only
    v = viewer
    goto(v, "control")
    v.find_element("id", "cmd-disarm").click()
    assert "refused: no valid token" in wait_until("refusal", lambda: text(v, "message"))
    fill(v, "token", hmi.token)
    fill(v, "op-name", "second")
    v.find_element("id", "take").click()
    assert "control is held by operator" in wait_until(
        "view only", lambda: "refused" in text(v, "message") and text(v, "message"))
    assert text(d, "ctl-mode") == "WALKING"  # nothing the viewer did changed the device

    # ... but the viewer's E-stop (the Esc key) stops the device
    goto(v, "live")
    v.find_element("tag name", "body").send_keys("\ue00c")  # Escape
    wait_until("fault", lambda: text(d, "ctl-mode") == "FAULT")
    shot(v, "estop")
    applied = wait_until("the E-stop applied", lambda: [
        a for a in httpx.get(f"{hmi.url}/api/log").json()
        if a["source"] == "loop" and a["command"] == "estop"])
    assert applied[0]["after_click_ms"] < 50.0  # the goal, end to end on loopback
    d.find_element("id", "end").click()
    folder = next(hmi.sessions.glob("*-Ada"))
    wait_until("the session's summary", lambda: (folder / "run.json").exists(), timeout=30)

    # the runtime's log: the torque is zero from the E-stop's tick on
    from exoleg.runtime.log import read_log

    _, cols, _ = read_log(folder / "session.log")
    k = applied[0]["tick"]
    assert cols["mode"][k] == 3 and cols["mode"][k - 1] == 2
    for j in ("hip", "knee", "ankle"):
        assert np.any(cols[f"u_{j}"][:k] != 0.0)
        assert np.all(cols[f"u_{j}"][k:] == 0.0)
    actions = [json.loads(x) for x in (folder / "control.log").read_text().splitlines()]
    seen = [(a["command"].split()[0], a["accepted"]) for a in actions if a["source"] != "loop"]
    for expected in (("start", True), ("arm", True), ("walk", True), ("gains", False),
                     ("gains", True), ("disarm", False), ("take", False), ("estop", True)):
        assert expected in seen, (expected, seen)
    assert all(a["time"] > 0 and a["source"] for a in actions)


def test_sessions_page_lists_plots_and_exports(hmi: Any, operator: Any) -> None:
    d = operator
    goto(d, "sessions")
    row = wait_until("the session listed", lambda: [
        r for r in d.find_elements("css selector", "#sessions tbody tr")
        if "Ada" in r.text])[0]
    assert "the operator ended the session: torque off" in row.text
    row.click()
    wait_until("the plot", lambda: d.execute_script(
        "const i = document.getElementById('session-plot'); return i && i.complete && "
        "i.naturalWidth > 0;"), timeout=60)
    shot(d, "sessions")
    folder = next(hmi.sessions.glob("*-Ada"))
    from exoleg.runtime.log import read_log

    _, cols, _ = read_log(folder / "session.log")
    csv_href = d.find_element("id", "export-csv").get_attribute("href")
    r = httpx.get(csv_href, timeout=60)
    lines = r.text.splitlines()
    assert r.status_code == 200 and lines[0].split(",")[:3] == ["t", "late", "q_meas_hip"]
    assert len(lines) == len(cols["t"]) + 1
    import pyarrow.parquet as pq

    pq_href = d.find_element("id", "export-parquet").get_attribute("href")
    table = pq.read_table(io.BytesIO(httpx.get(pq_href, timeout=60).content))
    assert np.array_equal(table.column("u_ankle").to_numpy(), cols["u_ankle"])


def _server_keeps_off_the_loops_cpu(server: int) -> None:
    """The server runs off the loop's CPU (the last one, none being isolated here) and
    the session's process has the CPUs the server was started with (this test's)."""
    import os

    from exoleg.runtime.realtime import isolated_cpus

    cpus = os.sched_getaffinity(0)
    if len(cpus) < 2 or isolated_cpus():
        return
    assert os.sched_getaffinity(server) == cpus - {max(cpus)}
    kids = Path(f"/proc/{server}/task/{server}/children").read_text().split()
    sessions = [int(k) for k in kids
                if b"resource_tracker" not in Path(f"/proc/{k}/cmdline").read_bytes()]
    assert len(sessions) == 1, kids
    assert os.sched_getaffinity(sessions[0]) == cpus
