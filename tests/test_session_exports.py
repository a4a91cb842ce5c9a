"""A session for a gait lab (issue 42): C3D through ezc3d and Motion-BIDS, each read back
by its own reader (ezc3d; the BIDS files by the csv module and json) to the same angles
and events as the session's log, and a CSV whose header carries the units.

References: the session log itself (exoleg.session_log.read_log: the encoders' angles,
the detector's events), exoleg's signs turned clinical by docs/conventions.md (knee
flexion negative in exoleg), C3D's 16-bit frame count (65,535), and the Motion-BIDS
specification (BIDS 1.9: channels.tsv's name, component, type, tracked_point, units;
motion.json's TaskName, SamplingFrequency, TrackingSystemName)."""

from __future__ import annotations

import csv
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from conftest import REALTIME
from exoleg.runtime.exports import C3D_MAX_FRAMES, session_export, write_c3d
from exoleg.runtime.session import run
from exoleg.session_log import read_log
from exoleg.tick import Event


@pytest.fixture(scope="module")
def session(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("exports") / "s"
    run("sim", 6.0, folder, arm=True, walk_after=1.0, realtime=REALTIME)
    return folder


def _truth(session: Path) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    _, cols, _ = read_log(session / "session.log")
    q = np.degrees(np.stack([cols["q_meas_hip"], -cols["q_meas_knee"],
                             cols["q_meas_ankle"]], axis=1))
    ev = cols["events"].astype(np.int64)
    return cols["t"], q, cols["t"][(ev & Event.IC) > 0], cols["t"][(ev & Event.TO) > 0]


def cli(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "exoleg.cli", "log", "export", *args],
                          capture_output=True, text=True, timeout=300)


def test_c3d_reads_back_to_the_same_angles_and_events(session: Path, tmp_path: Path) -> None:
    ezc3d = pytest.importorskip("ezc3d", reason="ezc3d (exoleg[report])")
    r = cli(str(session), "--c3d", str(tmp_path / "s.c3d"))
    assert r.returncode == 0, r.stderr
    c = ezc3d.c3d(str(tmp_path / "s.c3d"))
    t, q, ic, to = _truth(session)
    labels = c["parameters"]["POINT"]["LABELS"]["value"]
    assert labels == ["RHipAngles", "RKneeAngles", "RAnkleAngles"]
    assert c["parameters"]["POINT"]["ANGLES"]["value"] == labels
    assert c["parameters"]["POINT"]["RATE"]["value"][0] == 1000.0
    pts = c["data"]["points"]
    assert pts.shape == (4, 3, len(t))
    # C3D stores single precision: 6e-8 relative
    assert np.allclose(pts[0].T, q, rtol=1e-6, atol=1e-5)
    ev = c["parameters"]["EVENT"]
    times = ev["TIMES"]["value"][1]
    strikes = sorted(times[i] for i, lab in enumerate(ev["LABELS"]["value"])
                     if lab == "Foot Strike")
    offs = sorted(times[i] for i, lab in enumerate(ev["LABELS"]["value"]) if lab == "Foot Off")
    assert np.allclose(strikes, ic - t[0], atol=1e-6) and np.allclose(offs, to - t[0], atol=1e-6)
    assert set(ev["CONTEXTS"]["value"]) == {"Right"}
    units = dict(zip(c["parameters"]["ANALOG"]["LABELS"]["value"],
                     c["parameters"]["ANALOG"]["UNITS"]["value"], strict=True))
    assert units["hip_u"] == "Nm" and units["knee_cuff"] == "Nm"


def test_motion_bids_reads_back_to_the_same_angles_and_events(session: Path,
                                                               tmp_path: Path) -> None:
    r = cli(str(session), "--bids", str(tmp_path / "bids"))
    assert r.returncode == 0, r.stderr
    folder = tmp_path / "bids" / "sub-unknown" / "motion"
    stem = "sub-unknown_task-walking_tracksys-exoleg"
    desc = json.loads((tmp_path / "bids" / "dataset_description.json").read_text())
    assert desc["BIDSVersion"] == "1.9.0" and desc["Name"]
    meta = json.loads((folder / f"{stem}_motion.json").read_text())
    assert meta["TaskName"] == "walking" and meta["SamplingFrequency"] == 1000.0
    assert meta["TrackingSystemName"] and meta["JNTANGChannelCount"] == 6
    with (folder / f"{stem}_channels.tsv").open() as f:
        channels = list(csv.DictReader(f, delimiter="\t"))
    assert list(channels[0]) == ["name", "component", "type", "tracked_point", "units",
                                 "description"]
    assert meta["MotionChannelCount"] == len(channels)
    rows = [[float("nan") if x == "n/a" else float(x) for x in ln.split("\t")]
            for ln in (folder / f"{stem}_motion.tsv").read_text().splitlines()]
    data = np.array(rows)
    t, q, ic, to = _truth(session)
    names = [c["name"] for c in channels]
    got = data[:, [names.index(n) for n in ("hip_flexion", "knee_flexion",
                                            "ankle_dorsiflexion")]]
    assert data.shape == (len(t), len(channels))
    assert np.allclose(got, q, rtol=1e-8, atol=1e-7)  # 9 significant digits
    assert [c["units"] for c in channels[:3]] == ["deg"] * 3
    with (folder / f"{stem}_events.tsv").open() as f:
        events = list(csv.DictReader(f, delimiter="\t"))
    strikes = [float(e["onset"]) for e in events if e["trial_type"] == "Right Foot Strike"]
    assert np.allclose(strikes, ic - t[0], atol=1e-4)


def test_csv_has_units_and_decimates_by_block_means(session: Path, tmp_path: Path) -> None:
    r = cli(str(session), "--csv", str(tmp_path / "s.csv"), "--rate", "250")
    assert r.returncode == 0, r.stderr
    with (tmp_path / "s.csv").open() as f:
        head = next(csv.reader(f))
    assert head[:4] == ["t [s]", "hip_flexion [deg]", "knee_flexion [deg]",
                        "ankle_dorsiflexion [deg]"]
    data = np.loadtxt(tmp_path / "s.csv", delimiter=",", skiprows=1)
    t, q, _, _ = _truth(session)
    n = len(t) // 4 * 4
    assert np.allclose(data[:, 1:4], q[:n].reshape(-1, 4, 3).mean(axis=1), rtol=1e-8)
    assert np.allclose(np.diff(data[:, 0]), 0.004)
    for bad, said in ((["--rate", "300"], "divided by a whole number"),
                      # 0 Hz was an internal error (a division by zero)
                      (["--rate", "0"], "0 Hz: the tick rate (1000 Hz) divided"),
                      (["--csv", str(tmp_path / "x.txt")], "name a .csv file"),
                      ([], "give one of them"),
                      # a dataset written into the recording's own folder (it was)
                      (["--bids", str(session / "bids")], "in the session's own folder")):
        args = [str(session), *bad] if bad[:1] != ["--rate"] else [
            str(session), "--csv", str(tmp_path / "y.csv"), *bad]
        r = cli(*args)
        assert r.returncode == 2 and said in r.stderr and "Traceback" not in r.stderr, r.stderr
    assert not (session / "bids").exists()


def test_a_thirty_minute_session_exports(session: Path, tmp_path: Path) -> None:
    """30 minutes at 1 kHz (the fixture's records repeated, each copy's clock moved on):
    C3D in files of at most 65,535 frames, every frame kept, in order. Each file's frames
    as its header numbers them (C3D's words 4 and 5, the first and last frame: what a
    reader reads that many frames by), the first and last files read whole by ezc3d."""
    pytest.importorskip("ezc3d", reason="ezc3d (exoleg[report])")
    import struct

    import ezc3d

    from conftest import tile_session

    long = tmp_path / "long"
    header, ticks, final = tile_session(session, 1800.0, long)
    files = write_c3d(session_export(long), tmp_path / "long.c3d")
    assert len(files) == -(-ticks // C3D_MAX_FRAMES)
    first, last_file = (ezc3d.c3d(str(f)) for f in (files[0], files[-1]))
    frames = []
    for f in files:
        with open(f, "rb") as c3d:
            lo, hi = struct.unpack("<6xHH", c3d.read(10))
        frames.append(hi - lo + 1)
    assert sum(frames) == ticks and max(frames) == C3D_MAX_FRAMES
    assert first["data"]["points"].shape[2] == frames[0]
    assert last_file["data"]["points"].shape[2] == frames[-1]
    last = last_file["data"]["points"][0, 0, -1]
    assert last == pytest.approx(np.degrees(final[header["columns"].index("q_meas_hip")]),
                                 rel=1e-6)


def test_a_session_with_no_tick_or_a_damaged_child_record_is_said(session: Path,
                                                                   tmp_path: Path) -> None:
    """A session killed as it started (its log's header and no tick) exported "wrote "
    with no C3D file and exit 0, and a BIDS dataset of no samples; a child.json that is
    not a record (a list) was an internal error. Now: nothing to export, said; the
    damaged record exported without its details (the side's default, subject unknown)."""
    import json
    import shutil

    from exoleg.runtime.exports import session_export

    empty = tmp_path / "empty"
    shutil.copytree(session, empty)
    log = (session / "session.log").read_bytes()
    (empty / "session.log").write_bytes(log[:log.index(b"\n") + 1])
    for args in (["--c3d", str(tmp_path / "e.c3d")], ["--bids", str(tmp_path / "eb")],
                 ["--csv", str(tmp_path / "e.csv")]):
        r = cli(str(empty), *args)
        assert r.returncode == 2 and "0 ticks recorded: nothing to export" in r.stderr \
            and "Traceback" not in r.stderr, r.stderr
    assert not any((tmp_path / n).exists() for n in ("e.c3d", "eb", "e.csv"))
    damaged = tmp_path / "damaged"
    shutil.copytree(session, damaged)
    for record, subject in (([1, 2], "unknown"),
                            ({"affected_side": 3, "child_id": "../x"}, "../x")):
        (damaged / "child.json").write_text(json.dumps(record))
        exp = session_export(damaged)  # (the BIDS writer keeps a subject's letters only)
        assert exp.subject == subject
        assert exp.channels[0].tracked_point.startswith("Right")
