"""A child's record over time (issue 42): three sessions of one child in the console's
records, each with the figures kept when it ended, listed, shown with the trend of their
Gait Profile Score against its minimal clinically important difference (1.6 deg, Baker
et al. 2012), and exported; the child named only when asked.

References: each session's own figures (exoleg.runtime.figures, tested against their
definitions in tests/test_report.py) -- the history must carry them unchanged -- and the
MCID."""

from __future__ import annotations

import csv
import json
import subprocess
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from conftest import REALTIME
from exoleg.hmi.history import child_history
from exoleg.hmi.registry import FILE, Registry
from exoleg.runtime.session import run


@pytest.fixture(scope="module")
def records(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, str]:
    root = tmp_path_factory.mktemp("sessions")
    reg = Registry(root / FILE)
    cid = reg.add_child("Ada")
    fit = reg.add_fit(cid, {"child": {"name": "Ada"}}, "")
    other = reg.add_child("Ben")
    for k, (walk, noise) in enumerate(((1.0, 0), (2.0, 1), (3.0, 2))):
        name = f"2026120{k + 1}-100000-{cid}"
        run("sim", 5.0, root / name, arm=True, walk_after=walk, realtime=REALTIME, seed=noise)
        reg.add_session(name, cid, fit, 1796300000.0 + 86400 * k, operator="therapist")
    reg.note(f"20261201-100000-{cid}", "first session; tolerated well")
    reg.add_session("lost-session", other, None, 1796300000.0)  # no folder: no figures
    reg.close()
    return root, cid


def test_the_history_carries_each_sessions_figures(records: tuple[Path, str]) -> None:
    root, cid = records
    h = child_history(root, cid)
    assert h["name"] == "Ada" and len(h["sessions"]) == 3
    assert [s["started"] for s in h["sessions"]] == sorted(s["started"] for s in h["sessions"])
    for s in h["sessions"]:
        kept = json.loads((root / s["name"] / "figures.json").read_text())
        for k in ("walk_time_s", "steps", "gps_deg", "cadence_steps_per_min"):
            assert s[k] == kept[k], k
        # the assistance trended: per joint, the mean over the phases of the kept figure
        for j, by_phase in kept["assistance"].items():
            assert s["assistance"][j] == pytest.approx(np.mean(list(by_phase.values())))
        assert s["settings"] is None  # run without the console: nothing carried
    gps = [s["gps_deg"] for s in h["sessions"]]
    assert h["gps_change_deg"] == pytest.approx(gps[-1] - gps[0])
    assert h["beyond_mcid"] == (abs(gps[-1] - gps[0]) > 1.6)
    # the walk started later each time: less walking time, in that order
    walks = [s["walk_time_s"] for s in h["sessions"]]
    assert walks[0] > walks[1] > walks[2]
    assert h["sessions"][0]["note"] == "first session; tolerated well"


def test_the_command_lists_shows_and_exports(records: tuple[Path, str], tmp_path: Path,
                                             here: Any) -> None:
    root, cid = records

    def cli(*a: str) -> subprocess.CompletedProcess[str]:
        return here("child", *a, "--sessions", str(root))

    r = cli("list")
    assert r.returncode == 0 and cid in r.stdout and "Ada" not in r.stdout, r.stdout
    assert "Ada" in cli("list", "--name").stdout
    r = cli("show", cid)
    assert r.returncode == 0 and "3 session(s)" in r.stdout and "Ada" not in r.stdout
    assert "Gait Profile Score" in r.stdout and "clinically important difference" in r.stdout
    r = cli("export", cid, "--out", str(tmp_path / "h.csv"))
    assert r.returncode == 0, r.stderr
    rows = list(csv.DictReader((tmp_path / "h.csv").open()))
    assert len(rows) == 3 and float(rows[0]["gps_deg"]) == pytest.approx(
        child_history(root, cid)["sessions"][0]["gps_deg"])
    r = cli("export", cid, "--out", str(tmp_path / "h.json"))
    assert json.loads((tmp_path / "h.json").read_text())["name"] is None  # not asked
    run = next(root.glob("*/run.json"))  # a session's own record (it was written over)
    kept = run.read_bytes()
    for bad, said in ((("show", "Cffffffff"), "no such child"),
                      (("export", cid, "--out", str(tmp_path / "h.txt")), "a .csv or .json"),
                      (("export", cid, "--out", str(run)), "run.json is the name of a "
                       "session's own record")):
        r = cli(*bad)
        assert r.returncode == 2 and said in r.stderr and "Traceback" not in r.stderr
    assert run.read_bytes() == kept


def test_a_sessions_report_shows_the_childs_sessions_up_to_it(records: tuple[Path, str],
                                                               tmp_path: Path,
                                                               here: Any) -> None:
    pypdf = pytest.importorskip("pypdf", reason="pypdf (exoleg[dev])")
    root, cid = records
    h = child_history(root, cid)
    names = [s["name"] for s in h["sessions"]]

    def text(session: str) -> str:
        out = tmp_path / f"{session}.pdf"
        r = here("report", str(root / session), "--out", str(out))
        assert r.returncode == 0, r.stderr
        return "\n".join(p.extract_text() for p in pypdf.PdfReader(out).pages)

    last = text(names[-1])
    assert "This child's sessions" in last
    assert f"Gait Profile Score {h['gps_change_deg']:+.1f} deg since the first session" in last
    assert last.count("2026-") >= 3  # its three sessions (and its own date)
    first = text(names[0])
    assert "One scored session so far." in first  # the later ones are not in its report
    assert f"Child: {cid}" in first and "Ada" not in first
