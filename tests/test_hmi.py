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
import re
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest

pytest.importorskip("starlette", reason="starlette (exoleg[api])")
httpx = pytest.importorskip("httpx", reason="httpx (exoleg[dev])")

import exoleg.hmi  # noqa: E402
from conftest import http  # noqa: E402
from exoleg.hmi.testing import (  # noqa: E402
    browser_missing,
    chromium,
    served_hmi,
    wait_until,
)
from exoleg.runtime.link import BEAT_CHECK_TICKS  # noqa: E402

#: how long the page waits for the E-stop's answer before it says it did not reach the
#: device (hmi.js's ESTOP_WAIT_MS, read from the page the browser runs)
ESTOP_WAIT_MS = float(re.search(  # type: ignore[union-attr]
    r"const ESTOP_WAIT_MS = (\d+);", (Path(exoleg.hmi.__file__).parent / "static" /
                                     "hmi.js").read_text()).group(1))

missing = browser_missing()
pytestmark = pytest.mark.skipif(bool(missing), reason=f"no headless browser: {missing}")

SHOTS = Path(__file__).resolve().parents[1] / "build" / "screenshots"


def AUTH(hmi: Any) -> dict[str, str]:
    return {"Authorization": f"Bearer {hmi.token}"}


def ada_folder(hmi: Any) -> Path:
    info = http.get(f"{hmi.url}/api/info", headers=AUTH(hmi)).json()
    return next(hmi.sessions.glob(f"*-{info['child']['child_id']}"))


def text(driver: Any, id_: str) -> str:
    return str(driver.find_element("id", id_).text)


def shot(driver: Any, name: str) -> None:
    SHOTS.mkdir(parents=True, exist_ok=True)
    driver.save_screenshot(str(SHOTS / f"{name}.png"))


def goto(driver: Any, page: str) -> None:
    driver.find_element("id", f"nav-{page}").click()
    wait_until(f"page {page}", lambda: driver.find_element("id", f"page-{page}").is_displayed())


def press(driver: Any, id_: str) -> None:
    """Click ``id_`` as a person does on a small screen: scrolled to the middle first
    (not under the sticky header)."""
    e = driver.find_element("id", id_)
    driver.execute_script("arguments[0].scrollIntoView({block: 'center'})", e)
    e.click()


def fill(driver: Any, id_: str, value: object) -> None:
    e = driver.find_element("id", id_)
    e.clear()
    e.send_keys(str(value))


def armed_walk(driver: Any, start: str, length: str, seconds: float) -> None:
    """Start a session from the Control page (``start``'s button, its ``length`` field
    ``seconds``), armed as it starts, then walk: standing, then walking."""
    goto(driver, "control")
    fill(driver, length, seconds)
    if not driver.find_element("id", "arm-start").is_selected():
        press(driver, "arm-start")
    press(driver, start)
    wait_until("armed, standing", lambda: text(driver, "ctl-mode") == "STANDING", timeout=60)
    press(driver, "cmd-walk")
    wait_until("walking", lambda: text(driver, "ctl-mode") == "WALKING")


def fill_child(driver: Any, name: str, age: str, height: str, mass: str) -> Any:
    """The Child page's form filled with a child's name, age, height and mass."""
    form = driver.find_element("id", "child-form")
    for field_name, value in (("name", name), ("age", age), ("height", height),
                              ("mass", mass)):
        field = form.find_element("name", field_name)
        field.clear()
        field.send_keys(value)
    return form


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


@pytest.fixture(autouse=True)
def no_session_left_running(request: pytest.FixtureRequest) -> Any:
    """A test that fails midway leaves its session running on the module's console:
    ended here by its operator, so the next test meets a device at rest and not the first
    failure again (a CI run once failed three tests for one)."""
    yield
    if "operator" not in request.fixturenames:
        return
    hmi, d = request.getfixturevalue("hmi"), request.getfixturevalue("operator")

    def running() -> bool:
        return http.get(f"{hmi.url}/api/state").json()["running"] in ("starting",
                                                                       "running")
    if running():
        op = d.execute_script("return S.operator") or ""
        http.post(f"{hmi.url}/api/session/end", headers={**AUTH(hmi), "X-Operator": op})
        wait_until("the session left running ended", lambda: not running(), timeout=30)


def test_child_page_fits_and_keeps_the_child(hmi: Any, operator: Any) -> None:
    d = operator
    goto(d, "control")
    d.find_element("id", "take").click()
    wait_until("control taken", lambda: "you (operator) hold control" in text(d, "hdr-operator"))
    goto(d, "child")
    # a child the datasheets' device carries walking (issue 21: at 24 V, with its gears'
    # ratings, a 9-year-old of 27 kg already faults at the knee; 8 y, 25 kg walks)
    form = fill_child(d, "Ada", "8", "126", "25")
    form.find_element("name", "spasticity").send_keys("mild")  # the child as an actor
    d.find_element("id", "fit").click()
    verdict = wait_until("the fit's verdict", lambda: text(d, "verdict"), timeout=60)
    # the same child through exoleg's own fitting (exoleg.design.report.fit_report)
    from exoleg.design.report import fit_report
    from exoleg.sizing import Child

    rep = fit_report(Child(age=8, sex="female", height=1.26, mass=25, name="Ada"))
    assert verdict == rep.verdict
    page = text(d, "fit-result")
    assert f"upper (hip-knee) {rep.fit.upper * 100:.1f} cm" in page
    assert f"lower (knee-sole) {rep.fit.lower * 100:.1f} cm" in page
    wait_until("the child listed", lambda: "Ada (C" in text(d, "children"))
    # kept in the records (the token's), under a pseudonymous id
    info = http.get(f"{hmi.url}/api/info", headers=AUTH(hmi)).json()
    (ada,) = [c for c in info["children"] if c["name"] == "Ada"]
    assert info["child"]["verdict"] == rep.verdict and info["child"]["child_id"] == ada["id"]
    assert f"Ada ({ada['id']}, fit " in info["runs_on"]
    # on the simulated device the session carries her as an actor (docs/child.md), as
    # the form set her
    assert ("simulated as an actor (typically developing strength, mild spasticity"
            in info["runs_on"])
    assert "mild spasticity" in text(d, "actor")
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
    # the support mode: transparent and back while walking, blended, no fault
    assert text(d, "ctl-support") == "impedance"
    d.find_element("id", "cmd-transparent").click()
    wait_until("transparent", lambda: text(d, "ctl-support") == "transparent")
    d.find_element("id", "cmd-impedance").click()
    wait_until("impedance again", lambda: text(d, "ctl-support") == "impedance")
    assert text(d, "ctl-mode") == "WALKING"
    shot(d, "control")
    _server_keeps_off_the_loops_cpu(hmi.process.pid)

    # Live: read at >= 20 Hz (the stream is 50 Hz; the floor for a person to
    # read), the leg drawn with exoleg's kinematics. The page counts the updates of the
    # last 2 s; on a machine whose cores the suite's other workers fill it read 16 once
    # (the whole suite's CPU 30 % above its usual), so the test waits for a window of 2 s
    # at that rate, for up to 10 s, rather than reading the first
    goto(d, "live")
    time.sleep(2.5)
    wait_until("2 s of the live view at >= 20 updates per s",
               lambda: float(text(d, "rate").split()[0]) >= 20.0, 10, every=0.5,
               seen=lambda: text(d, "rate"))
    q, pts, lengths = d.execute_script(
        "const s = S.state, dv = S.info.device;"
        "return [s.q, legPoints(s.q, dv.lengths, dv.offsets), dv.lengths];")
    import exoleg

    ada = exoleg.load_leg(ada_folder(hmi) / "leg.toml")
    assert lengths == pytest.approx(list(ada.lengths), abs=1e-12)  # the fitted child's leg
    fk = ada.fk(np.array(q))
    for i, point in enumerate(("hip", "knee", "ankle", "toe")):
        assert pts[i] == pytest.approx(list(fk[point]), abs=1e-12)
    assert text(d, "phase") in ("swing", "loading", "foot flat", "push-off")
    # the simulated foot board sends its FSRs and IMU: the detector says it rests on both
    assert text(d, "gait-source") == "the FSRs and the foot's IMU"
    # the cuffs' torque per kg against the limit the safety layer enforces: the shipped
    # safety.toml [cuffs] (Schwartz et al. 2008, very fast walkers' peak moment + 2 SD)
    rows = d.execute_script(  # at once: the table is drawn anew at every frame
        "return [...document.querySelectorAll('#cuffs tr')].slice(1).map("
        "(r) => [...r.cells].map((c) => c.textContent))")
    assert rows[1] == ["limit (N m/kg)", "2.5", "1.3", "1.9"]
    cuff, mass = d.execute_script("return [S.state.cuff, S.state.body_mass]")
    assert mass == pytest.approx(25.0)  # Ada, as the Child page fitted her
    now = [float(x) for x in rows[0][1:]]
    assert all(0.0 <= x < 2.5 * 3 for x in now)  # read, not torque off (3 x the limit)
    assert len(rows[2]) == 4 and all(x.endswith("%") for x in rows[2][1:])
    assert "torque off" in text(d, "cuff-rule")
    assert cuff is not None and len(cuff) == 3
    # the load on the foot sensors in % body weight: the board's counts through its
    # response inverted (FootSensors.newtons), the page's figure against Python's
    shown, fsr, page = d.execute_script(  # at once: the state moves at 50 Hz
        "return [document.getElementById('foot-load').textContent, S.state.fsr, "
        "footLoad(S.state)]")
    from exoleg.device.sensors import FootSensors

    board = FootSensors.default(noise_scale=0.0)
    want = 100 * sum(board.newtons(c) for c in fsr) / (25.0 * 9.81)  # Ada: 25 kg
    # the page interpolates the inverse every 16 counts: within 0.5 % body weight
    assert shown.endswith("% body weight") and page == pytest.approx(want, abs=0.5)
    shot(d, "live")

    # Gains: outside the bounds refused with the reason, inside accepted
    goto(d, "control")
    wait_until("gains shown", lambda: d.find_element("id", "g-kp_swing-2"))
    g = http.get(f"{hmi.url}/api/gains").json()
    kp = g["gains"]["kp_swing"][2]
    fill(d, "g-kp_swing-2", 3 * kp)
    d.find_element("id", "apply-gains").click()
    msg = wait_until("refusal", lambda: "refused" in text(d, "message") and text(d, "message"))
    assert f"kp_swing[2] = {3 * kp:g} is outside 0-{2 * kp:g}" in msg
    fill(d, "g-kp_swing-2", 1.5 * kp)
    fill(d, "g-support-0", 0.6)
    # assist-as-needed's bounds per joint, in the same table
    fill(d, "g-support_min-1", 0.3)
    d.find_element("id", "apply-gains").click()
    wait_until("gains in force", lambda: http.get(f"{hmi.url}/api/gains").json()["gains"]
             ["support"] == [0.6])
    now = http.get(f"{hmi.url}/api/gains").json()["gains"]
    assert now["kp_swing"][2] == pytest.approx(1.5 * kp) and now["support_min"][1] == 0.3

    # A second person: no token -> refused; with the token, control is held -> view only
    v = viewer
    goto(v, "control")
    assert not v.find_element("id", "cmd-disarm").is_enabled()  # not while walking
    v.find_element("id", "cmd-stand").click()
    assert "refused: no valid token" in wait_until("refusal", lambda: text(v, "message"))
    fill(v, "token", hmi.token)
    fill(v, "op-name", "second")
    v.find_element("id", "take").click()
    # (the page still says the last refusal until the answer to "take" comes: under load
    # a wait for any refusal read that one)
    wait_until("view only", lambda: "control is held by operator" in text(v, "message"),
               seen=lambda: text(v, "message"))
    assert text(d, "ctl-mode") == "WALKING"  # nothing the viewer did changed the device

    # ... but the viewer's E-stop (its key, F2) stops the device
    goto(v, "live")
    v.find_element("tag name", "body").send_keys("\ue032")  # F2
    wait_until("fault", lambda: text(d, "ctl-mode") == "FAULT")
    shot(v, "estop")
    applied = wait_until("the E-stop applied", lambda: [
        a for a in http.get(f"{hmi.url}/api/log", headers=AUTH(hmi)).json()
        if a["source"] == "loop" and a["command"] == "estop"])
    # The loop looks for an E-stop at every tick, ahead of everything else; the slowest
    # thing on the path it must not wait for is the heartbeat check, every
    # BEAT_CHECK_TICKS ticks (100 ms): the server's receipt to the tick that wrote the
    # drives' command is the software's part (measured 1.5 ms quiet and with two
    # CPU-bound processes beside the suite's test). From the click it adds the browser's
    # event and the request, which the host's load decides: the goal (<= 50 ms)
    # is timed by benchmarks/bench_hmi.py on a quiet host (5.6 ms here quiet, 20.8 ms
    # with two CPU-bound processes; 136 ms once in CI beside another worker's files);
    # the bound here is the page's own, ESTOP_WAIT_MS, beyond which it says the E-stop
    # did not reach the device and sends it again (test_hmi_safety.py's case 4).
    # A page that had no answer within ESTOP_WAIT_MS said so and sent it again (each try
    # carries the press's time): once in a full run on two cores the first try's answer
    # came late and the retry was the one applied.
    first = applied[0]
    assert 0.0 < first["after_request_ms"] < BEAT_CHECK_TICKS * 1.0, first  # 1 ms a tick
    assert first["after_request_ms"] < first["after_click_ms"], first
    if first["after_click_ms"] >= ESTOP_WAIT_MS:
        wait_until(f"a late E-stop said on the page ({first})", lambda: "(sent " in text(
            v, "message"), 10, seen=lambda: text(v, "message"))
    d.find_element("id", "end").click()
    folder = ada_folder(hmi)
    wait_until("the session's summary", lambda: (folder / "run.json").exists(), timeout=30)

    # the runtime's log: the torque is zero from the E-stop's tick on
    from exoleg.session_log import read_log

    head, cols, _ = read_log(folder / "session.log")
    # the session carried Ada as an actor: her child.toml, the cuffs' torque logged
    assert (folder / "child.toml").exists() and head["child"] == "Ada"
    from exoleg.child.model import ChildModel

    assert ChildModel.load(folder / "child.toml").spasticity.level == "mild"
    assert np.all(np.isfinite(cols["interaction_knee"][1:]))
    k = applied[0]["tick"]
    assert cols["mode"][k] == 3 and cols["mode"][k - 1] == 2
    for j in ("hip", "knee", "ankle"):
        assert np.any(cols[f"u_{j}"][:k] != 0.0)
        assert np.all(cols[f"u_{j}"][k:] == 0.0)
    actions = [json.loads(x) for x in (folder / "control.log").read_text().splitlines()]
    seen = [(a["command"].split()[0], a["accepted"]) for a in actions if a["source"] != "loop"]
    for expected in (("start", True), ("arm", True), ("walk", True), ("gains", False),
                     ("gains", True), ("stand", False), ("take", False), ("estop", True)):
        assert expected in seen, (expected, seen)
    assert all(a["time"] > 0 and a["source"] for a in actions)


def test_sessions_page_lists_plots_and_exports(hmi: Any, operator: Any) -> None:
    d = operator
    goto(d, "sessions")
    row = wait_until("the session listed", lambda: [
        r for r in d.find_elements("css selector", "#sessions tbody tr")
        if "Ada" in r.text])[0]
    # how it ended in a clinician's words (exoleg.runtime.figures.stop_in_words), the
    # runtime's own on the cell's title
    from exoleg.runtime.figures import session_figures, stop_in_words

    folder = ada_folder(hmi)
    stopped = json.loads((folder / "run.json").read_text())["stopped_by"]
    assert stopped.startswith("the operator ended the session: torque off (after an E-stop")
    assert stop_in_words(stopped) in row.text and \
        row.find_elements("css selector", "td")[4].get_attribute("title") == stopped
    assert "whole" in row.text  # its records are not damaged
    row.click()
    wait_until("the plot", lambda: d.execute_script(
        "const i = document.getElementById('session-plot'); return i && i.complete && "
        "i.naturalWidth > 0;"), timeout=60)
    shot(d, "sessions")
    # the session in a clinician's units: its own figures (tests/test_report.py checks
    # them against their definitions)
    fig = session_figures(folder)
    said = dict(d.execute_script(
        "return [...document.querySelectorAll('#session-clinical tr')].map("
        "(r) => [r.cells[0].textContent, r.cells[1].textContent])"))
    assert said["steps, cadence"].startswith(f"{fig['steps']} steps, ")
    assert said["how it ended"] == stop_in_words(stopped)
    assert said["Gait Profile Score"] == ("-" if fig["gps_deg"] is None
                                          else f"{fig['gps_deg']:.1f} deg")
    assert said["time in the device, armed / walking"].endswith(
        f"{fig['walk_time_s'] / 60:.1f} min")
    rom = said["range of motion hip / knee / ankle (typical)"]
    assert rom.startswith(f"{fig['rom_deg']['hip']:.0f} ({fig['normative_rom_deg']['hip']:.0f})")
    assert said["cuffs' peak torque hip / knee / ankle (of the limit)"].endswith("N m/kg")
    from exoleg.session_log import read_log

    _, cols, _ = read_log(folder / "session.log")
    csv_href = hmi.url + d.find_element("id", "export-csv").get_attribute("data-file")
    assert http.get(csv_href, timeout=60).status_code == 401  # the records need the token
    r = http.get(csv_href, timeout=60, headers=AUTH(hmi))
    lines = r.text.splitlines()
    assert r.status_code == 200 and lines[0].split(",")[:3] == ["t", "late", "q_meas_hip"]
    assert len(lines) == len(cols["t"]) + 1
    import pyarrow.parquet as pq

    pq_href = hmi.url + d.find_element("id", "export-parquet").get_attribute("data-file")
    table = pq.read_table(io.BytesIO(http.get(pq_href, timeout=60,
                                              headers=AUTH(hmi)).content))
    assert np.array_equal(table.column("u_ankle").to_numpy(), cols["u_ankle"])
    # the report for the clinic's file (issue 42): the PDF, its figures read back
    pypdf = pytest.importorskip("pypdf", reason="pypdf (exoleg[dev])")
    report = hmi.url + d.find_element("id", "session-report").get_attribute("data-file")
    assert http.get(report, timeout=60).status_code == 401
    r = http.get(report, timeout=120, headers=AUTH(hmi))
    assert r.status_code == 200 and r.headers["content-type"] == "application/pdf"
    text = "\n".join(p.extract_text() for p in pypdf.PdfReader(io.BytesIO(r.content)).pages)
    assert f"Steps (either foot)\n{fig['steps']}" in text
    assert "Stopped by the emergency stop" in text
    # pseudonymous: the console's id, not the name (Ada)
    assert "Child: C" in text and "Ada" not in text
    c3d = hmi.url + d.find_element("id", "export-c3d").get_attribute("data-file")
    r = http.get(c3d, timeout=120, headers=AUTH(hmi))
    assert r.status_code == 200 and r.content[1:2] == b"\x50"  # C3D's key: 0x50
    # the child's page opens on their history: this session among them, its figures
    goto(d, "child")
    # found and clicked in one script: the list is drawn again as the page refreshes
    wait_until("Ada listed and picked", lambda: d.execute_script(
        "const a = [...document.querySelectorAll('#children a')]"
        ".find((x) => x.textContent.includes('Ada')); if (a) a.click(); return !!a;"))
    rows = wait_until("her sessions", lambda: d.execute_script(
        "return [...document.querySelectorAll('#history-table tr')].slice(1)"
        ".map((r) => r.textContent)"))
    assert len(rows) >= 1 and "operator" in rows[-1]
    assert f"{fig['steps']}" in rows[-1]


def _server_keeps_off_the_loops_cpu(server: int) -> None:
    """The server runs off the loop's CPU (the last one, none being isolated here) and
    the session's process has the CPUs the server was started with (this test's)."""
    import os

    from conftest import session_processes
    from exoleg.runtime.realtime import isolated_cpus

    cpus = os.sched_getaffinity(0)
    if len(cpus) < 2 or isolated_cpus():
        return
    assert os.sched_getaffinity(server) == cpus - {max(cpus)}
    sessions = session_processes(server)
    assert len(sessions) == 1, sessions
    assert os.sched_getaffinity(sessions[0]) == cpus


# ---------------------------------------------------------------- issue 20, point 7 and 2
#: WCAG 2.1 AA contrast of every visible text against its background (1.4.3: 4.5:1, 3:1
#: for large text -- 24 px, or 18.66 px bold); disabled controls are exempt. The formula
#: is WCAG's relative luminance.
CONTRAST_JS = """
const lin = (v) => { v /= 255;
  return v <= 0.03928 ? v / 12.92 : Math.pow((v + 0.055) / 1.055, 2.4); };
const lum = (c) => 0.2126 * lin(c[0]) + 0.7152 * lin(c[1]) + 0.0722 * lin(c[2]);
const rgb = (s) => (s.match(/[\\d.]+/g) || []).map(Number);
const back = (el) => { for (; el; el = el.parentElement) {
  const v = rgb(getComputedStyle(el).backgroundColor);
  if (v.length === 3 || (v.length === 4 && v[3] > 0.5)) return v.slice(0, 3); }
  return [255, 255, 255]; };
const bad = [];
for (const el of document.querySelectorAll("body *")) {
  if (!el.getClientRects().length || el.disabled || el.closest("[disabled]")) continue;
  if (![...el.childNodes].some((n) => n.nodeType === 3 && n.textContent.trim())) continue;
  const st = getComputedStyle(el);
  if (st.visibility === "hidden") continue;
  const a = lum(rgb(st.color)), b = lum(back(el));
  const ratio = (Math.max(a, b) + 0.05) / (Math.min(a, b) + 0.05);
  const px = parseFloat(st.fontSize), large = px >= 24 || (px >= 18.66 && +st.fontWeight >= 700);
  if (ratio < (large ? 3 : 4.5))
    bad.push(`${el.id || el.tagName} "${el.textContent.trim().slice(0, 30)}": `
             + ratio.toFixed(2));
}
return bad;
"""

#: the E-stop on screen and not covered: its centre is inside the viewport and the
#: element there is the button itself
ESTOP_SEEN_JS = """
const b = document.getElementById("estop"), r = b.getBoundingClientRect();
const x = r.left + r.width / 2, y = r.top + r.height / 2;
const top = document.elementFromPoint(x, y);
return r.width > 60 && r.height > 40 && x > 0 && y > 0 && x < innerWidth && y < innerHeight
  && (top === b || b.contains(top));
"""


@pytest.fixture(scope="module")
def console(tmp_path_factory: pytest.TempPathFactory) -> Any:
    with served_hmi(tmp_path_factory.mktemp("console") / "sessions") as served:
        yield served


def test_the_console_tells_the_truth_and_guides(console: Any) -> None:
    hmi = console
    phone = chromium(360, 640)  # a phone, as an operator might hold one
    desk = chromium(1400, 1000)  # a person watching, no token
    try:
        phone.get(hmi.page)
        desk.get(hmi.url + "/#live")
        assert "token" not in phone.current_url  # read, then kept out of the history
        # first contact: what to do first, on the page it opens on
        wait_until("the guide", lambda: phone.find_element("id", "guide").is_displayed())
        assert "Take control" in text(phone, "guide") and "Fit the child" in text(phone,
                                                                                  "guide")
        for page in ("live", "child", "control", "sessions"):  # the E-stop at 360 px
            goto(phone, page)
            phone.execute_script("window.scrollTo(0, document.body.scrollHeight)")
            assert phone.execute_script(ESTOP_SEEN_JS), page
            assert phone.execute_script(CONTRAST_JS) == [], page
            shot(phone, f"phone-{page}")
            goto(desk, page)
            assert desk.execute_script(CONTRAST_JS) == [], page
        goto(desk, "sessions")  # the records need the token
        wait_until("records refused", lambda: "need the token" in text(desk,
                                                                        "sessions-note"))

        # a session, armed at the start: the buttons the mode allows
        goto(phone, "control")
        press(phone, "take")
        wait_until("control", lambda: "hold control" in text(phone, "hdr-operator"))
        assert "no child fitted: the paper's leg" in text(phone, "runs-on")
        fill(phone, "duration", 120)
        press(phone, "arm-start")
        # a double tap starts one session: the second tap, before the first's answer,
        # meets a button switched off (not a second start refused as the first one's
        # session -- a CI run once saw that refusal after one click)
        phone.execute_script("const b = document.getElementById('start'); "
                             "b.scrollIntoView({block: 'center'}); b.click(); b.click();")
        wait_until("standing", lambda: text(phone, "ctl-mode") == "STANDING", timeout=60,
                   seen=lambda: (text(phone, "ctl-mode"), text(phone, "hdr-mode"),
                                 text(phone, "message"), text(phone, "ended-text")))
        assert "for no child fitted: the paper's leg" in text(phone, "message")
        starts = [a for a in http.get(f"{hmi.url}/api/log", headers=AUTH(hmi)).json()
                  if a["command"].startswith("start")]
        assert [a["accepted"] for a in starts] == [True], starts
        enabled = {b.get_attribute("data-command"): b.is_enabled()
                   for b in phone.find_elements("css selector", "[data-command]")}
        assert enabled == {"arm": False, "stand": False, "walk": True, "disarm": True,
                           "reset": False, "impedance": True, "transparent": True,
                           "aan": True}
        assert not phone.find_element("id", "start").is_enabled()
        # a command the supervisor refuses says why, in its words
        phone.execute_script("act('POST', '/api/command', {command: 'arm'}, 'arm applied')")
        assert wait_until("the refusal", lambda: "supervisor" in text(phone, "message") and
                          text(phone, "message")) == (
            "refused by the supervisor: arm refused in STANDING: arming needs DISARMED "
            "(after a fault: reset first)")
        # Disarm while standing asks first; "No" leaves it standing
        press(phone, "cmd-disarm")
        wait_until("the question", lambda: phone.find_element("id", "confirm").is_displayed())
        assert "torque goes off" in text(phone, "confirm-text")
        shot(phone, "phone-confirm")
        press(phone, "confirm-no")
        wait_until("not disarmed", lambda: text(phone, "message") == "not disarmed")
        assert text(phone, "ctl-mode") == "STANDING"
        # an empty field is refused in the form's words; a decimal comma is read
        wait_until("gains shown", lambda: phone.find_element("id", "g-support-0"))
        fill(phone, "g-support-0", "")
        press(phone, "apply-gains")
        assert wait_until("refused", lambda: "refused" in text(phone, "message") and
                          text(phone, "message")) == "refused: support: empty; enter a number"
        fill(phone, "g-support-0", "0,6")
        press(phone, "apply-gains")
        wait_until("0,6 in force", lambda: http.get(f"{hmi.url}/api/gains").json()
                   ["gains"]["support"] == [0.6])
        # the transparent law for this child: its rows in the operator's words, with the
        # bounds the gears' modes set (the ankle's no further than the device's own 0.3);
        # a share beyond them refused with the reason, one within applied (the table
        # shown again from the server first: "0,6" as typed, then 0.6 as in force)
        wait_until("the table again", lambda: phone.find_element(
            "id", "g-support-0").get_attribute("value") == "0.6")
        rows = text(phone, "gains")
        assert "inertia_share (0-1, the device's inertia the transparent law takes)" in rows
        assert "accel_filter_hz (Hz, the transparent law's acceleration estimate)" in rows
        fill(phone, "g-inertia_share-2", "0.5")
        press(phone, "apply-gains")
        assert wait_until("refused", lambda: "refused" in text(phone, "message") and
                          text(phone, "message")).startswith(
            "refused: inertia_share[2] = 0.5 is outside 0-0.3 (the law's gear modes")
        fill(phone, "g-inertia_share-2", "0.3")
        fill(phone, "g-inertia_share-0", "0,7")
        press(phone, "apply-gains")
        wait_until("0,7 in force", lambda: http.get(f"{hmi.url}/api/gains").json()
                   ["gains"]["inertia_share"] == [0.7, 0.3, 0.3])

        # walking: Live shows the time, the steps, the assistance, every gait event
        press(phone, "cmd-walk")
        wait_until("walking", lambda: text(phone, "ctl-mode") == "WALKING")
        goto(phone, "live")
        time.sleep(4.0)
        assert text(phone, "support") == "60 %"
        assert int(text(phone, "steps")) >= 2 and text(phone, "t-session").endswith(" s")
        shot(phone, "phone-live-walking")

        # the operator's page goes away mid-walk: the hold lapses, the child is stood
        # and the device disarmed (never armed with nobody in control), every open page
        # shows the alarm
        from exoleg.runtime.operator import LEASE_S

        phone.get("about:blank")
        alarm = wait_until("the alarm on the watching page", lambda: desk.find_element(
            "id", "alarm").is_displayed() and text(desk, "alarm"), timeout=LEASE_S + 5)
        assert "link lost: operator's hold on control lapsed" in alarm
        assert "controlled stop to standing, then disarm" in alarm
        # stood, then disarmed: the loop applied both (its control log); the simulated
        # leg, with no muscles of its own, may then fold past its range within a few
        # tenths of a second (a fault), quicker than a page's poll may catch DISARMED
        walking = max((p for p in hmi.sessions.iterdir() if p.name.endswith("paper-leg")),
                      key=lambda p: p.name)
        wait_until("stood, then disarmed", lambda: [
            a["command"] for a in map(json.loads, (walking / "control.log").read_text()
                                      .splitlines())
            if a["source"] == "loop" and a["accepted"]][-2:] == ["stand", "disarm"],
            timeout=10)
        wait_until("the page shows it", lambda: text(desk, "hdr-mode") in ("DISARMED",
                                                                          "FAULT"))
        shot(desk, "desk-alarm")
        phone.get(hmi.page)  # back: take control again, and arm
        goto(phone, "control")
        press(phone, "take")
        wait_until("control", lambda: "hold control" in text(phone, "hdr-operator"))
        wait_until("the alarm acknowledged", lambda: not desk.find_element(
            "id", "alarm").is_displayed())
        # the walked session ends (the simulated leg, disarmed with no muscles of its own,
        # folds past its range: a fault); every step and event was on the watching page
        walked = walking
        press(phone, "end")
        wait_until("ended", lambda: (walked / "run.json").exists(), timeout=30)
        time.sleep(0.5)
        from exoleg.control.gait_phase import Event
        from exoleg.session_log import read_log

        _, cols, _ = read_log(walked / "session.log")
        ev = cols["events"].astype(int)
        # reference: the session's own log, tick by tick; seen by the page that watched
        # the whole session (the operator's page reloaded in between)
        assert desk.execute_script("return S.hist[S.hist.length - 1].steps") == \
            int(((ev & Event.IC) > 0).sum())
        assert desk.execute_script("return S.eventCount") == sum(
            int(((ev & e) > 0).sum()) for e in Event)

        # the E-stop in a new session, armed at its start: the fault named, with what
        # going on needs; only Reset and Disarm
        wait_until("a new session offered", lambda: phone.find_element(
            "id", "start").is_enabled(), timeout=30)
        if not phone.find_element("id", "arm-start").is_selected():  # the page reloaded
            press(phone, "arm-start")
        press(phone, "start")
        wait_until("standing", lambda: text(phone, "ctl-mode") == "STANDING", timeout=60,
                   seen=lambda: (text(phone, "ctl-mode"), text(phone, "hdr-mode"),
                                 text(phone, "message"), text(phone, "ended-text")))
        press(phone, "estop")
        banner = wait_until("the fault", lambda: phone.find_element(
            "id", "fault-banner").is_displayed() and text(phone, "fault-banner"))
        assert banner == ("FAULT, torque off: E-stop. To go on: Reset (with the E-stop "
                          "released), then Arm.")
        enabled = {b.get_attribute("data-command"): b.is_enabled()
                   for b in phone.find_elements("css selector", "[data-command]")}
        assert enabled == {"arm": False, "stand": False, "walk": False, "disarm": True,
                           "reset": True, "impedance": False, "transparent": False,
                           "aan": False}
        shot(phone, "phone-fault")
        press(phone, "end")
        folder = max((p for p in hmi.sessions.iterdir() if p.name.endswith("paper-leg")),
                     key=lambda p: p.name)
        assert folder != walked
        wait_until("ended", lambda: (folder / "run.json").exists(), timeout=30)
        run = json.loads((folder / "run.json").read_text())
        assert run["stopped_by"].startswith("the operator ended the session: torque off "
                                            "(after an E-stop at")

        # the server gone: the page says so within a second or so, and the E-stop says it
        # could not reach the device
        hmi.process.kill()
        hmi.process.wait()
        gone = time.time()
        wait_until("link lost", lambda: "LOST" in text(phone, "hdr-link"), timeout=5)
        assert time.time() - gone < 2.0  # STALE_MS (1 s) after the last update, and a frame
        assert "cannot see the device" in text(phone, "link-lost")
        press(phone, "estop")
        assert "DID NOT REACH THE DEVICE" in wait_until(
            "the E-stop's failure", lambda: "REACH" in text(phone, "message") and
            text(phone, "message"))
        shot(phone, "phone-link-lost")
    finally:
        phone.quit()
        desk.quit()


def test_identification_is_a_step_of_fitting(hmi: Any, operator: Any) -> None:
    """Issue 25: the operator interface offers identification as a step of fitting. The
    operator starts it for the kept child (Ada), arms (at the start: the simulated child
    folds when disarmed), Walk starts the plan, the session ends by itself once the plan
    has played, and the identified leg becomes her kept fit: the next session runs on
    it. Reference: the identification's own record (exoleg.identify.device)."""
    d = operator
    armed_walk(d, "identify", "plan", 10)  # Walk starts the plan
    shot(d, "identify")
    info = http.get(f"{hmi.url}/api/info", headers=AUTH(hmi)).json()
    folder = next(hmi.sessions.glob(f"*-{info['child']['child_id']}-identify"))
    wait_until("the plan played", lambda: (folder / "identified" / "identify.json").exists(),
               timeout=90)
    result = json.loads((folder / "identified" / "identify.json").read_text())
    assert all(v < 6.0 for v in result["held_out_pct"].values()), result["held_out_pct"]
    run = json.loads(wait_until("the session's summary", lambda: (
        folder / "run.json").exists() and (folder / "run.json").read_text(), timeout=30))
    assert run["stopped_by"].startswith("the reference played to its end"), run
    # kept: the next session runs on the identified leg
    runs_on = wait_until("the identified leg kept", lambda: (
        lambda i: "(identified)" in i["runs_on"] and i["runs_on"])(
        http.get(f"{hmi.url}/api/info", headers=AUTH(hmi)).json()), timeout=30)
    assert "Ada (" in runs_on
    import exoleg

    kept = exoleg.load_leg(folder / "identified" / "leg.toml")
    assert kept.name in runs_on
    actions = [json.loads(x) for x in (folder / "control.log").read_text().splitlines()]
    said = [a for a in actions if a["command"] == "identification"]
    assert said and said[0]["accepted"] and "kept for the next sessions" in said[0]["why"]


def test_a_childs_record_and_settings_follow_them(hmi: Any, operator: Any) -> None:
    """Issue 42: another child fitted, then Ada picked again from the list keeps her
    last fit -- the leg identified above -- with no re-fit; a session of hers ends in
    assist as needed with a stiffer stance; her page shows her sessions with their
    figures and the trend; the Control page says, before the next session starts, the
    settings it starts with; and that session starts with them, on her identified leg.
    References: the records (each session's figures.json, tested against their
    definitions in tests/test_report.py) and what the operator set."""
    d = operator
    api = f"{hmi.url}/api"

    def ada() -> dict[str, Any]:
        kids = http.get(f"{api}/info", headers=AUTH(hmi)).json()["children"]
        return next(c for c in kids if c["name"] == "Ada")

    def history() -> dict[str, Any]:
        return dict(http.get(f"{api}/children/{ada()['id']}/history",
                             headers=AUTH(hmi)).json())

    def runs_on() -> str:
        return str(http.get(f"{api}/info", headers=AUTH(hmi)).json()["runs_on"])

    fits = ada()["fits"]
    goto(d, "child")
    press(d, "new-child")
    fill_child(d, "Ben", "8", "128", "26")
    press(d, "fit")
    wait_until("Ben kept", lambda: runs_on().startswith("Ben ("), timeout=60)
    # Ada again, from the list: her last fit (the identified leg), not a new one
    d.execute_script("[...document.querySelectorAll('#children a')].find("
                     "(a) => a.textContent.startsWith('Ada (')).click()")
    # the button names the child it keeps: the last child's history is gone the moment
    # Ada is picked, and only hers comes back
    wait_until("her history", lambda: "Keep Ada's" in d.find_element("id", "child-history").text)
    press(d, "keep-child")
    on = wait_until("Ada kept", lambda: runs_on().startswith("Ada (") and runs_on())
    assert "(identified)" in on and ada()["fits"] == fits

    # a session of hers: walking, then assist as needed and a stiffer stance at the hip;
    # ended by the operator once the gain is in force and she has walked two strides in
    # it (a 12 s session once ran out before the gain was applied, in a full run on two
    # cores under load: the gains asked of a session that had ended)
    armed_walk(d, "start", "duration", 120)
    press(d, "cmd-aan")
    wait_until("assist as needed", lambda: text(d, "ctl-support") == "aan")
    hip = wait_until("the gains table", lambda: d.find_element(
        "id", "g-kp_stance-0").get_attribute("value"))
    stiffer = round(1.5 * float(hip), 3)
    fill(d, "g-kp_stance-0", stiffer)
    press(d, "apply-gains")
    wait_until("the gain in force", lambda: http.get(f"{api}/gains").json()["gains"][
        "kp_stance"][0] == pytest.approx(stiffer))
    steps = d.execute_script("return S.hist[S.hist.length - 1].steps")
    wait_until("two strides with it", lambda: d.execute_script(
        "return S.hist[S.hist.length - 1].steps") >= steps + 4)
    press(d, "end")
    wait_until("the question", lambda: d.find_element("id", "confirm").is_displayed())
    press(d, "confirm-yes")
    h = wait_until("the session ended and its settings kept", lambda: (
        lambda x: (x["sessions"][-1]["settings"] or {}).get("support_mode") == "aan" and x)(
        history()), timeout=60)
    last = h["sessions"][-1]
    assert last["settings"]["gains"]["kp_stance"][0] == pytest.approx(stiffer)
    assert last["steps"] and last["steps"] > 0 and last["gps_deg"] is not None

    # her page: every session of hers with its figures, the trend, the settings to come
    goto(d, "child")
    d.execute_script("[...document.querySelectorAll('#children a')].find("
                     "(a) => a.textContent.startsWith('Ada (')).click()")
    wait_until("her history", lambda: "assist as needed" in text(d, "history-settings"))
    rows = d.execute_script(
        "return [...document.querySelectorAll('#history-table tr')].slice(1).map("
        "(r) => [...r.cells].map((c) => c.textContent))")
    assert len(rows) == len(h["sessions"]) >= 3
    for row, s in zip(rows, h["sessions"], strict=True):
        kept = json.loads((hmi.sessions / s["name"] / "figures.json").read_text())
        assert row[2] == ("-" if kept["steps"] is None else str(kept["steps"]))
        assert row[4] == ("-" if kept["gps_deg"] is None else f"{kept['gps_deg']:.1f} deg")
    assert rows[-1][5] == "aan"
    scored = [s["gps_deg"] for s in h["sessions"] if s["gps_deg"] is not None]
    assert len(scored) >= 2
    assert f"{scored[-1] - scored[0]:+.1f} deg since the first session" in text(
        d, "history-trend")
    shot(d, "child-history")

    # before the next session starts: what it runs on and the settings it starts with
    goto(d, "control")
    said = wait_until("the settings to come", lambda: (
        lambda t: "ended with: assist as needed" in t and t)(text(d, "runs-on")))
    assert f"the settings session {last['name']} ended with" in said and \
        "(identified)" in said
    fill(d, "duration", 3)
    press(d, "start")
    folder = hmi.sessions / wait_until("the fourth session", lambda: (
        lambda n: n != last["name"] and n)(http.get(f"{api}/info").json()["session"]))
    wait_until("started in assist as needed", lambda: text(d, "ctl-support") == "aan",
               timeout=60)
    # read afresh each time: the table is redrawn as the session starts (an element found
    # once went stale before its value was read, in a fresh-clone CI run under load)
    def gain_shown() -> float:
        return float(d.find_element("id", "g-kp_stance-0").get_attribute("value"))

    wait_until("the kept gain shown", lambda: gain_shown() == pytest.approx(stiffer),
               seen=gain_shown)
    lines = [json.loads(x) for x in (folder / "control.log").read_text().splitlines()]
    (line,) = [a for a in lines if a["command"] == "kept settings"]
    assert line["accepted"] and f"kept from session {last['name']}" in line["why"]
    assert "(identified)" in (folder / "leg.toml").read_text()
    shot(d, "kept-settings")
    wait_until("the fourth session ended", lambda: (folder / "run.json").exists(),
               timeout=30)
