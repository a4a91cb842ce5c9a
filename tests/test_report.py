"""The clinician's session report (issue 42): a session's figures from its own records
(exoleg.runtime.figures) and the PDF a clinic files (exoleg report), read back with
pypdf and its pages rendered with pdfium.

References: the walking controller's stride (the simulated device walks 1.1 s strides:
data/device/walking_control.toml) and the definitions -- cadence 120 / stride time
(steps of either foot per minute), the GVS the RMS difference from the normative mean
over the cycle every 2 % (Baker 2009) -- computed here by hand from the log's columns."""

from __future__ import annotations

import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from conftest import REALTIME
from exoleg.runtime.figures import session_figures, stop_in_words
from exoleg.runtime.session import run
from exoleg.session_log import read_log
from exoleg.tick import Event


@pytest.fixture(scope="module")
def session(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("report") / "s"
    run("sim", 12.0, folder, arm=True, walk_after=1.0, realtime=REALTIME)
    return folder


def test_the_sessions_figures_are_their_definitions(session: Path) -> None:
    fig = session_figures(session)
    _, cols, _ = read_log(session / "session.log")
    t = cols["t"]
    ic = t[(cols["events"].astype(np.int64) & Event.IC) > 0]
    assert fig["initial_contacts"] == len(ic) and fig["steps"] == 2 * len(ic)
    # whole strides walked: 1.1 s each (the controller's), within the detector's timing
    assert fig["stride_time_s"][0] == pytest.approx(1.1, abs=0.05)
    assert fig["cadence_steps_per_min"] == pytest.approx(120 / fig["stride_time_s"][0])
    assert 55 < fig["stance_percent"] < 65  # typically developing children: ~60 %
    assert fig["walk_time_s"] == pytest.approx(11.0, abs=0.6)  # walked from 1 s to the stop
    assert fig["up_time_s"] == pytest.approx(len(t) * 1e-3, abs=2e-3)  # armed throughout
    # the GVS by hand: each whole stride on the 2 % grid, averaged, against the
    # normative mean (the device's hip: zeroed standing, exoleg.reference.scores)
    from exoleg.reference import scores

    q = scores.clinical_degrees(np.stack([cols[f"q_meas_{j}"] for j in
                                          ("hip", "knee", "ankle")], 1))
    mode = cols["mode"].astype(int)
    k = np.nonzero((cols["events"].astype(np.int64) & Event.IC) > 0)[0]
    walking = (2, 4)  # Mode.WALKING, Mode.STOPPING
    strides = [(a, b) for a, b in zip(k[:-1], k[1:], strict=True)
               if np.all(np.isin(mode[a:b + 1], walking))]
    assert len(strides) == fig["strides"] >= 6
    grid = np.arange(0, 101, 2) / 100
    cycle = np.mean([[np.interp(t[a] + g * (t[b] - t[a]), t, q[:, j]) for j in range(3)]
                     for a, b in strides for g in [grid]], axis=0).T
    mean, _ = scores.normative_cycle(upright=True)
    gvs = np.sqrt(np.mean((cycle - mean) ** 2, axis=0))
    assert [fig["gvs_deg"][j] for j in ("hip", "knee", "ankle")] == pytest.approx(gvs, rel=1e-9)
    assert fig["gps_deg"] == pytest.approx(np.sqrt(np.mean(gvs**2)), rel=1e-9)
    # the cuffs' torque per kg against the shipped limit (safety.toml [cuffs])
    assert [fig["cuffs"][j]["limit_Nm_per_kg"] for j in ("hip", "knee", "ankle")] == \
        [2.5, 1.3, 1.9]
    assert fig["stopped_in_words"].startswith("The planned time ended; the device brought "
                                              "the leg to standing")


def test_the_report_reads_back_and_renders(session: Path, tmp_path: Path) -> None:
    pypdf = pytest.importorskip("pypdf", reason="pypdf (exoleg[dev])")
    pdfium = pytest.importorskip("pypdfium2", reason="pypdfium2 (exoleg[dev])")
    out = tmp_path / "report.pdf"
    t0 = time.perf_counter()
    r = subprocess.run([sys.executable, "-m", "exoleg.cli", "report", str(session), "--out",
                        str(out)], capture_output=True, text=True, timeout=120)
    took = time.perf_counter() - t0
    assert r.returncode == 0, r.stderr
    fig = session_figures(session)
    text = "\n".join(p.extract_text() for p in pypdf.PdfReader(out).pages)
    assert f"Steps (either foot)\n{fig['steps']}" in text
    assert f"Walking time\n{fig['walk_time_s'] / 60:.1f} min" in text
    assert f"Gait Profile Score (hip, knee, ankle)\n{fig['gps_deg']:.1f} deg" in text
    assert "The planned time ended" in text
    pdf = pdfium.PdfDocument(str(out))
    assert 2 <= len(pdf) <= 4
    for i in range(len(pdf)):
        img = np.asarray(pdf[i].render(scale=0.5).to_pil().convert("L"))
        # ink on every page (measured: 0.7 % of page 1's pixels, text only; blank: 0)
        assert img.shape[0] > 300 and (img < 128).mean() > 0.003, i
    pdf.close()
    assert took < 30  # the command, interpreter start included (a 12 s session)
    # no name unless asked: the session ran without the console's records
    assert "not recorded" in text


def test_stops_in_a_clinicians_words() -> None:
    assert stop_in_words("E-stop: torque off") == \
        "Stopped by the emergency stop: the motors were switched off at once."
    assert stop_in_words("duration: torque off (after a fault: OVERSPEED (knee) at 3.2 s)") \
        .startswith("The device stopped itself on a fault")
    assert stop_in_words("loop overrun: tick 5 started 60 ms late") \
        .startswith("The control computer stopped the session")
    # no run.json (a killed session) or an unreadable one said "The session ended."
    assert stop_in_words("").startswith("Not recorded: the session's run.json is missing")


def test_a_report_is_a_pdf_and_never_over_a_record(session: Path, tmp_path: Path,
                                                   here: Any) -> None:
    for target, said in ((tmp_path / "r.txt", "a report is a PDF"),
                         (session / "run.json", "a report is a PDF"),
                         (tmp_path, "a report is a PDF")):
        r = here("report", str(session), "--out", str(target))
        assert r.returncode == 2 and said in r.stderr and "Traceback" not in r.stderr, \
            r.stderr
    r = here("report", str(tmp_path))
    assert r.returncode == 2 and "no session log here" in r.stderr


def test_a_damaged_run_record_or_a_vanished_device_folder_keeps_the_figures(
        session: Path, tmp_path: Path, here: Any) -> None:
    """run.json a list, or its fields of other types (a hand-edited or damaged record),
    was an internal error that lost the whole report; the session's device folder since
    moved or deleted would have been too. The figures come from the log; how the session
    ended reads as not recorded; the cuffs' limit is the one the log's header recorded
    as the session started (the shipped safety.toml's [cuffs] here: 2.5 / 1.3 / 1.9)."""
    import json
    import shutil

    copy = tmp_path / "s"
    shutil.copytree(session, copy)
    whole = session_figures(session)
    limits = [whole["cuffs"][j]["limit_Nm_per_kg"] for j in ("hip", "knee", "ankle")]
    assert limits == [2.5, 1.3, 1.9]
    for damaged in ([1, 2], {"stopped_by": 7, "device": "my-device"}, "{\"stopped_by\": "):
        (copy / "run.json").write_text(damaged if isinstance(damaged, str)
                                       else json.dumps(damaged))
        fig = session_figures(copy)
        assert fig["steps"] == whole["steps"] and fig["gps_deg"] == whole["gps_deg"]
        assert fig["stopped_in_words"].startswith("Not recorded"), damaged
        assert [fig["cuffs"][j]["limit_Nm_per_kg"] for j in ("hip", "knee", "ankle")] == \
            limits
    # a log from before the header recorded the limit, its device folder since deleted:
    # the limit is not known, said as such (None), and the rest of the report stands
    from exoleg.session_log import read_header

    header, _ = read_header(copy / "session.log")
    assert header["device"]["cuff_limit_Nm_per_kg"] == limits
    from exoleg.runtime import figures

    gone = {"device": {"folder": str(tmp_path / "moved-away")}}
    assert all(np.isnan(figures._cuff_limits(gone, {})))
    (copy / "child.json").write_text("[1]")  # (a list: the report's name line failed)
    r = here("report", str(copy), "--out", str(tmp_path / "r.pdf"))
    assert r.returncode == 0 and "Traceback" not in r.stderr, r.stderr
