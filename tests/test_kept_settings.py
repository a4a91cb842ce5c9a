"""A child's settings follow them (issue 42): the support mode, gains, assist-as-needed
bounds and the transparent law's share and estimate the operator left at the end of a
child's session are kept in the records and given to the child's next session, by the
path an operator's change takes -- the same bounds (from the device's defaults, not from
the kept values: they cannot creep up session after session), the supervisor's answer, a
line in control.log. Settings the device's bounds no longer allow, or damaged ones, leave
the defaults and say why.

References: what the operator set (the loop's published gains are the walking
controller's own, exoleg.control.hierarchy.WalkController.gains_now) and the control
API's bounds (0 to twice the session's first gains, shares 0-1, the law's from its gears'
modes)."""

from __future__ import annotations

import asyncio
import contextlib
import json
import threading
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

pytest.importorskip("starlette", reason="starlette (exoleg[api])")

from exoleg.hmi.registry import Registry  # noqa: E402
from exoleg.hmi.server import HMI  # noqa: E402
from exoleg.runtime.link import LoopLink  # noqa: E402
from exoleg.tick import SupportMode  # noqa: E402


def _until(what: str, check: Any, timeout: float = 30.0) -> Any:
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if out := check():
            return out
        time.sleep(0.02)
    raise AssertionError(f"timed out waiting for {what}")


def _session(hmi: HMI, seconds: float = 3.0) -> tuple[str, Path]:
    """Start a session of the kept child (armed at the start) and wait for its gains."""
    status, out = hmi.start(seconds, "test", arm=True)
    assert status == 200, out
    _until("the session's gains", lambda: hmi.api.gains()[0] and LoopLink.running(
        hmi.api.link.web_copy()) == "running")
    return out["session"], hmi.root / out["session"]


@contextlib.contextmanager
def _console(tmp_path: Path, child: dict[str, Any]) -> Iterator[tuple[HMI, Registry, str]]:
    """A console (its records in ``tmp_path``) with ``child`` fitted and kept, and its
    watch running beside it as its server runs it (on an event loop of its own): the
    heartbeat its sessions' loops look for -- a link nobody beats is lost 1 s into the
    session; (the console, its records, the child's id), closed after."""
    hmi = HMI(tmp_path)
    reg = hmi.registry
    assert reg is not None
    loop = asyncio.new_event_loop()
    watch = loop.create_task(hmi.api.watch())
    thread = threading.Thread(target=lambda: loop.run_until_complete(
        asyncio.wait([watch])), daemon=True)
    thread.start()
    try:
        status, rec = hmi.fit(child, "test")
        assert status == 200, rec
        yield hmi, reg, rec["child_id"]
    finally:
        loop.call_soon_threadsafe(watch.cancel)
        thread.join(timeout=10)
        loop.close()
        hmi.close()
        reg.close()


def _ended(hmi: HMI, reg: Registry, cid: str, name: str) -> dict[str, Any]:
    """Wait for session ``name`` to end (by its duration: not a lost link) and its
    settings to be kept."""
    hmi.proc.join(timeout=30)
    run = json.loads((hmi.root / name / "run.json").read_text())
    assert run["stopped_by"].startswith("duration"), run["stopped_by"]
    return _until("the settings kept", lambda: (lambda k: k and k["session"] == name and k)(
        reg.kept_settings(cid)))


def _kept_lines(folder: Path) -> list[dict[str, Any]]:
    lines = [json.loads(x) for x in (folder / "control.log").read_text().splitlines()]
    return [a for a in lines if a["command"] == "kept settings"]


def test_a_childs_settings_follow_them_to_their_next_session(tmp_path: Path) -> None:
    ada = {"name": "Ada", "age": 8, "sex": "female", "height": 126, "mass": 25}
    with _console(tmp_path, ada) as (hmi, reg, cid):
        on = hmi.runs_on()
        assert on["settings"] is None and "default settings (no session of theirs yet)" \
            in on["text"]

        # 1. the operator's changes: a stiffer stance, assist as needed within bounds
        first, folder = _session(hmi)
        defaults, bounds = hmi.api.gains()
        change = {"kp_stance": [1.5 * x for x in defaults["kp_stance"]],
                  "support_min": [0.2, 0.3, 0.4],  # and the law this child walks best in
                  "inertia_share": [0.7, 0.6, 0.2], "accel_filter_hz": [60.0, 100.0, 30.0]}
        assert hmi.api.check_gains(change) == ""
        hmi.api.link.web_gains(change)
        why, _ = hmi.api.send("aan")
        assert why == ""
        kept = _ended(hmi, reg, cid, first)
        assert kept["support_mode"] == "aan"
        for k, v in change.items():
            assert kept["gains"][k] == pytest.approx(v, rel=1e-12), k
        assert kept["gains"]["kd_swing"] == pytest.approx(defaults["kd_swing"], rel=1e-12)
        on = hmi.runs_on()
        assert on["settings"]["session"] == first
        assert f"the settings session {first} ended with: assist as needed" in on["text"]
        assert ("transparent law: inertia share 0.7 / 0.6 / 0.2, its acceleration estimate "
                "60 / 100 / 30 Hz") in on["text"]

        # 2. the next session starts with them, its bounds still the device's defaults'
        second, folder = _session(hmi)
        (line,) = _until("the kept settings applied", lambda: _kept_lines(folder))
        assert line["accepted"] and f"kept from session {first}" in line["why"], line
        now = _until("the kept gains in force", lambda: (
            lambda g: g["kp_stance"] == pytest.approx(change["kp_stance"]) and g)(
            hmi.api.gains()[0]))
        for k in ("support_min", "inertia_share", "accel_filter_hz"):
            assert now[k] == pytest.approx(change[k]), k
        assert hmi.api.gains()[1] == bounds  # not twice the kept values
        assert _until("assist as needed", lambda: hmi.api.state()["support_mode"]
                      == SupportMode.AAN)
        _ended(hmi, reg, cid, second)

        # 3. settings a changed device no longer allows: refused, the defaults stay
        reg.keep_settings(second, {**kept, "gains": {**kept["gains"], "kp_stance": [
            3.0 * x for x in defaults["kp_stance"]]}})
        third, folder = _session(hmi)
        (line,) = _until("the kept settings refused", lambda: _kept_lines(folder))
        assert not line["accepted"] and "outside the device's bounds now: kp_stance[0]" \
            in line["why"] and "the defaults stay" in line["why"], line
        assert hmi.api.gains()[0]["kp_stance"] == pytest.approx(defaults["kp_stance"])
        assert hmi.api.state()["support_mode"] == SupportMode.IMPEDANCE
        _ended(hmi, reg, cid, third)

        # 4. damaged settings in the records: said, the defaults used
        with reg.lock:
            reg.db.execute("UPDATE sessions SET settings = ? WHERE name = ?",
                           (json.dumps({"support_mode": "fast", "gains": {}}), third))
        on = hmi.runs_on()
        assert on["settings"] is None and ("the kept ones are damaged: unknown support "
                                           "mode 'fast'") in on["text"]

        # 5. settings kept before the law was tunable (none of its share and estimate):
        # given, the law the device's own
        old = {k: v for k, v in kept["gains"].items()
               if k not in ("inertia_share", "accel_filter_hz")}
        reg.keep_settings(third, {**kept, "gains": old})
        assert "transparent law: the device's own (not kept then)" in hmi.runs_on()["text"]
        fourth, folder = _session(hmi)
        (line,) = _until("the kept settings applied", lambda: _kept_lines(folder))
        assert line["accepted"], line
        now = _until("the kept gains in force", lambda: (
            lambda g: g["kp_stance"] == pytest.approx(change["kp_stance"]) and g)(
            hmi.api.gains()[0]))
        for k in ("inertia_share", "accel_filter_hz"):
            assert now[k] == pytest.approx(defaults[k]), k
        _ended(hmi, reg, cid, fourth)


def test_a_session_killed_mid_write_ends_and_nothing_is_kept_from_it(tmp_path: Path) -> None:
    # A session's process ended by the OS while it wrote the shared block (SIGKILL: the
    # OOM killer, a crash) left the block mid-write for good: every copy of it failed,
    # so the console's watch of the session ended at the settings it read at the end --
    # the session was never said ended nor let go, and settings read from a torn block
    # could mix two writes. Fault injection: the session's process stopped (SIGSTOP),
    # its block marked mid-write, then killed. The console ends it, says so in its
    # control.log, keeps nothing of it, and the child's next session starts and ends
    # as any does.
    import os
    import signal

    ben = {"name": "Ben", "age": 9, "sex": "male", "height": 133, "mass": 29}
    with _console(tmp_path, ben) as (hmi, reg, cid):
        name, folder = _session(hmi, 30.0)
        link, pid = hmi.api.link, hmi.proc.pid
        assert link is not None
        os.kill(pid, signal.SIGSTOP)
        if float(link.view["seq"]) % 2 == 0:
            link.view["seq"] += 1.0  # odd: stopped while writing
        os.kill(pid, signal.SIGKILL)
        _until("the session let go", lambda: hmi.api.link is None)
        lines = [json.loads(x) for x in (folder / "control.log").read_text().splitlines()]
        (torn,) = [a for a in lines if a["command"] == "session ended mid-write"]
        assert not torn["accepted"] and f"exit code -{signal.SIGKILL.value}" in torn["why"]
        assert "the settings it ended with are not kept" in torn["why"], torn
        assert [a["command"] for a in lines][-1] == "session ended"
        assert hmi.api.state()["running"] == "none"
        assert reg.kept_settings(cid) is None  # nothing taken from the torn block
        second, _ = _session(hmi, 2.0)
        assert _ended(hmi, reg, cid, second)["support_mode"] == "impedance"


def test_a_childs_next_session_expects_their_own_stride(tmp_path: Path) -> None:
    # The walking controller times a walk's strides at 1.1 s until it has measured the
    # child's; a child walking their own (the simulated 10-year-olds: 1.12-1.19 s) had
    # the first stride's reference lead their swinging leg, and their toe caught the
    # belt (docs/design.md: on the example design's device, 48 children of 8-12 y, 8
    # assisted strides each, the children touching 13 -> 6 when the controller expected
    # 1.14 s from the start). The console gives a child's next session the mean stride
    # of their last one that walked the strides the detector averages (its figures).
    from exoleg.control.gait_settings import DetectorSettings

    ada = {"name": "Ada", "age": 10, "sex": "female", "height": 138, "mass": 32}
    with _console(tmp_path, ada) as (hmi, reg, cid):
        on = hmi.runs_on()
        assert on["expected_stride"] is None
        assert "expecting 1.1 s strides until theirs are measured" in on["text"]
        first, folder = _session(hmi, 9.0)
        why, _ = hmi.api.send("walk")
        assert why == ""
        _ended(hmi, reg, cid, first)
        assert json.loads((folder / "run.json").read_text())["expected_stride_s"] == 1.1
        figures = json.loads((folder / "figures.json").read_text())
        stride = figures["stride_time_s"][0]
        assert figures["strides"] >= DetectorSettings.default().strides_averaged
        assert 1.1 < stride < 1.25, figures["stride_time_s"]  # theirs, not the plan's
        on = hmi.runs_on()
        assert on["expected_stride"] == pytest.approx(stride, rel=1e-12)
        assert (f"expecting their {stride:.2f} s strides (session {first}: "
                f"{figures['strides']} strides)") in on["text"]
        second, folder = _session(hmi, 2.0)
        hmi.proc.join(timeout=30)
        run = json.loads((folder / "run.json").read_text())
        assert run["expected_stride_s"] == pytest.approx(stride, rel=1e-12)
        # a session too short to measure them, or damaged figures, do not replace it
        (folder / "figures.json").write_text('{"stride_time_s": "1.3", "strides": 9}')
        assert hmi.runs_on()["expected_stride"] == pytest.approx(stride, rel=1e-12)
