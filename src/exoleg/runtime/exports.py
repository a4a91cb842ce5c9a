"""A session as a gait lab reads it (issue 42): its joint angles, torques and foot loads
with their units, and its gait events, written as C3D (through ezc3d), as Motion-BIDS
(the BIDS extension for motion data, BIDS 1.9: ``*_motion.tsv``, ``*_channels.tsv``,
``*_motion.json``, ``*_events.tsv``) or as CSV with units in its header; optionally
decimated (block means: each sample the mean of the ticks it stands for).

Angles in clinical degrees (hip flexion, knee flexion, ankle dorsiflexion positive: a
gait lab's signs), torques in N m, time in s. Events: the device's leg's initial contacts
and toe offs as C3D's "Foot Strike" and "Foot Off" on the affected side.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from exoleg.errors import ParameterError
from exoleg.io import read_record
from exoleg.params.records import JOINTS
from exoleg.reference.scores import clinical_degrees
from exoleg.session_log import SESSION_COLUMNS, check_records, check_session, read_log
from exoleg.tick import SENSOR_POINTS, Event

F64 = NDArray[np.float64]
#: C3D's header counts frames in 16 bits: a longer recording is split into files
C3D_MAX_FRAMES = 65535
#: the foot board's columns of a session log, exported as they are (ADC counts)
FSR_COLUMNS = tuple(f"fsr_{s}" for s in SENSOR_POINTS)
ANGLE_NAMES = {"hip": "hip_flexion", "knee": "knee_flexion", "ankle": "ankle_dorsiflexion"}
C3D_ANGLES = {"hip": "HipAngles", "knee": "KneeAngles", "ankle": "AnkleAngles"}


@dataclass
class Channel:
    """One exported series: its name, values, units, Motion-BIDS type and the body part
    it tracks."""

    name: str
    values: F64
    units: str
    type: str = "MISC"
    tracked_point: str = "n/a"
    component: str = "n/a"
    description: str = ""


@dataclass
class SessionExport:
    """What an export writes: the time, the channels, the events and who walked."""

    t: F64
    rate_hz: float
    channels: list[Channel]
    events: list[tuple[float, str]] = field(default_factory=list)
    side: str = "Right"
    subject: str = "unknown"


def _decimate(x: F64, k: int) -> F64:
    n = len(x) // k * k
    return x[:n].reshape(-1, k, *x.shape[1:]).mean(axis=1) if k > 1 else x


def session_export(folder: str | Path, rate_hz: float | None = None) -> SessionExport:
    """A session's series and events, ready to write.

    Parameters
    ----------
    folder : str or Path
        The session's folder (``session.log``, ``run.json``; ``child.json`` when the
        console recorded it).
    rate_hz : float, optional
        The exported rate, Hz: the tick rate divided by a whole number (block means);
        default the tick rate.

    Returns
    -------
    SessionExport
    """
    root = Path(folder)
    path = root / "session.log"
    if not path.is_file():
        raise ParameterError(str(root), "session.log", "no session log here")
    names = [f"{what}_{j}" for what in ("q_meas", "q_ref", "u", "cuff", "support_level")
             for j in JOINTS]
    header, cols, _ = read_log(path, [*SESSION_COLUMNS, *names, *FSR_COLUMNS])
    check_session(path, header)
    check_records(path, cols)
    period = float(header.get("period", 1e-3))
    k = 1
    if rate_hz is not None:
        ratio = 1.0 / (period * rate_hz) if rate_hz > 0 else 0.0  # (0 divided; nan fails)
        if not (ratio >= 1 and abs(ratio - round(ratio)) < 1e-9):
            raise ParameterError("export", "--rate", f"{rate_hz:g} Hz: the tick rate "
                                 f"({1 / period:g} Hz) divided by a whole number")
        k = int(round(ratio))
    ticks = len(cols["t"])
    if ticks < k:  # (a session killed as it started: its header and no tick)
        raise ParameterError(str(path), "t", f"{ticks} ticks recorded: nothing to export"
                             + (f" at {rate_hz:g} Hz (one sample is {k} ticks)" if k > 1
                                else ""))
    child = read_record(root / "child.json")  # damaged: exported without its details
    side = "Left" if child.get("affected_side") == "left" else "Right"  # (the default)
    chans: list[Channel] = []
    names = [f"q_meas_{j}" for j in JOINTS]
    if all(n in cols for n in names):
        q = clinical_degrees(np.stack([cols[n] for n in names], axis=1))
        for i, j in enumerate(JOINTS):
            chans.append(Channel(ANGLE_NAMES[j], q[:, i], "deg", "JNTANG",
                                 f"{side}{j.capitalize()}", "x", f"the device's {j} encoder"))
    q_ref = [f"q_ref_{j}" for j in JOINTS]
    if all(n in cols for n in q_ref):
        r = clinical_degrees(np.stack([cols[n] for n in q_ref], axis=1))
        for i, j in enumerate(JOINTS):
            chans.append(Channel(f"{ANGLE_NAMES[j]}_reference", r[:, i], "deg", "JNTANG",
                                 f"{side}{j.capitalize()}", "x",
                                 "the controller's reference"))
    for prefix, unit, what in (("u", "N m", "the torque the controller commanded"),
                               ("cuff", "N m", "the cuffs' torque on the child (filtered)"),
                               ("support_level", "n/a", "the device's support (1 full)")):
        for j in JOINTS:
            n = f"{prefix}_{j}"
            if n in cols and np.any(np.isfinite(cols[n])):
                chans.append(Channel(f"{j}_{prefix}", cols[n], unit, "MISC",
                                     f"{side}{j.capitalize()}", "n/a", what))
    for n in FSR_COLUMNS:
        if n in cols:
            chans.append(Channel(n, cols[n], "n/a", "MISC", f"{side}Foot", "n/a",
                                 "the foot board's force sensor, ADC counts"))
    if not chans:
        raise ParameterError(str(root), "session.log", "holds no joint angles to export")
    for c in chans:
        c.values = _decimate(np.asarray(c.values, dtype=float), k)
    t = _decimate(cols["t"], k) if k > 1 else cols["t"]
    ev = cols["events"].astype(np.int64)
    events = sorted([(float(x), "Foot Strike") for x in cols["t"][(ev & Event.IC) > 0]]
                    + [(float(x), "Foot Off") for x in cols["t"][(ev & Event.TO) > 0]])
    return SessionExport(t=np.asarray(t, dtype=float), rate_hz=1.0 / (period * k),
                         channels=chans, events=events, side=side,
                         subject=str(child.get("child_id") or "unknown"))


def write_c3d(exp: SessionExport, path: str | Path) -> list[Path]:
    """Write the export as C3D (ezc3d): the joint angles as points ``RHipAngles`` ...
    (x the sagittal angle, deg; ``POINT:ANGLES``), the other channels as analogs with
    their units, the events in C3D's ``EVENT`` group. A recording of more than
    :data:`C3D_MAX_FRAMES` frames is written as consecutive files ``NAME-01.c3d``, ...

    Parameters
    ----------
    exp : SessionExport
        What to write (:func:`session_export`).
    path : str or Path
        The ``.c3d`` file.

    Returns
    -------
    list of Path
        The files written.
    """
    import ezc3d

    from exoleg.io import atomic_path

    target = Path(path)
    angles = [c for c in exp.channels if c.type == "JNTANG" and
              not c.name.endswith("_reference")]
    analog = [c for c in exp.channels if c not in angles]
    n = len(exp.t)
    parts = [(a, min(a + C3D_MAX_FRAMES, n)) for a in range(0, n, C3D_MAX_FRAMES)]
    out = []
    for i, (a, b) in enumerate(parts):
        c = ezc3d.c3d()
        labels = [exp.side[0] + C3D_ANGLES[ch.tracked_point[len(exp.side):].lower()]
                  for ch in angles]
        c["parameters"]["POINT"]["RATE"]["value"] = [exp.rate_hz]
        c["parameters"]["POINT"]["LABELS"]["value"] = tuple(labels)
        c["parameters"]["POINT"]["DESCRIPTIONS"]["value"] = tuple(ch.description
                                                                  for ch in angles)
        c["parameters"]["POINT"]["UNITS"]["value"] = ["deg"]
        pts = np.zeros((4, len(angles), b - a))
        for j, ch in enumerate(angles):
            pts[0, j] = ch.values[a:b]
        pts[3] = 1.0
        c["data"]["points"] = pts
        c.add_parameter("POINT", "ANGLES", labels)
        c.add_parameter("POINT", "ANGLE_UNITS", ["deg"])
        c["parameters"]["ANALOG"]["RATE"]["value"] = [exp.rate_hz]
        c["parameters"]["ANALOG"]["LABELS"]["value"] = tuple(ch.name for ch in analog)
        c["parameters"]["ANALOG"]["UNITS"]["value"] = tuple(ch.units.replace(" ", "")
                                                            for ch in analog)
        c["parameters"]["ANALOG"]["DESCRIPTIONS"]["value"] = tuple(ch.description
                                                                   for ch in analog)
        c["data"]["analogs"] = np.stack([ch.values[a:b] for ch in analog])[None, :, :]
        t0, t1 = exp.t[a], exp.t[b - 1]
        for when, label in exp.events:
            if t0 <= when <= t1:
                c.add_event([0, when - t0], context=exp.side, label=label)
        name = target if len(parts) == 1 else target.with_name(
            f"{target.stem}-{i + 1:02d}{target.suffix}")
        with atomic_path(name) as tmp:
            c.write(str(tmp.with_suffix(".c3d")))
            tmp.with_suffix(".c3d").replace(tmp)
        out.append(name)
    return out


def write_bids(exp: SessionExport, root: str | Path, task: str = "walking",
               tracksys: str = "exoleg") -> list[Path]:
    """Write the export as a Motion-BIDS dataset (BIDS 1.9): ``dataset_description.json``
    and, under ``sub-<child>/motion/``, ``*_motion.tsv`` (no header: the channels file
    names its columns), ``*_channels.tsv`` (name, component, type, tracked_point,
    units), ``*_motion.json`` and ``*_events.tsv`` (onset, duration, trial_type).

    Parameters
    ----------
    exp : SessionExport
        What to write (:func:`session_export`).
    root : str or Path
        The dataset's folder (made if missing).
    task : str, default "walking"
        The BIDS task label.
    tracksys : str, default "exoleg"
        The BIDS tracking-system label.

    Returns
    -------
    list of Path
        The files written.
    """
    import csv
    import re

    from exoleg import __version__
    from exoleg.io import atomic_path

    sub = re.sub(r"[^A-Za-z0-9]", "", exp.subject) or "unknown"
    base = Path(root)
    folder = base / f"sub-{sub}" / "motion"
    folder.mkdir(parents=True, exist_ok=True)
    stem = f"sub-{sub}_task-{task}_tracksys-{tracksys}"
    written = []

    def put(path: Path, write: Any) -> None:
        with atomic_path(path) as tmp, tmp.open("w", newline="", encoding="utf-8") as f:
            write(f)
        written.append(path)

    put(base / "dataset_description.json", lambda f: json.dump(
        {"Name": "exoleg sessions", "BIDSVersion": "1.9.0", "DatasetType": "raw",
         "GeneratedBy": [{"Name": "exoleg", "Version": __version__}]}, f, indent=2))
    def motion(f: Any) -> None:  # BIDS writes a missing value (NaN: not measured) n/a
        import io

        buf = io.StringIO()
        np.savetxt(buf, np.stack([c.values for c in exp.channels], axis=1), delimiter="\t",
                   fmt="%.9g")
        f.write(buf.getvalue().replace("nan", "n/a"))

    put(folder / f"{stem}_motion.tsv", motion)

    def channels(f: Any) -> None:
        w = csv.writer(f, delimiter="\t", lineterminator="\n")
        w.writerow(["name", "component", "type", "tracked_point", "units", "description"])
        for c in exp.channels:
            w.writerow([c.name, c.component, c.type, c.tracked_point, c.units,
                        c.description])

    put(folder / f"{stem}_channels.tsv", channels)
    counts: dict[str, int] = {}
    for c in exp.channels:
        counts[f"{c.type}ChannelCount"] = counts.get(f"{c.type}ChannelCount", 0) + 1
    put(folder / f"{stem}_motion.json", lambda f: json.dump(
        {"TaskName": task, "SamplingFrequency": exp.rate_hz,
         "TrackingSystemName": "exoleg: the exoskeleton's encoders and foot board",
         "MotionChannelCount": len(exp.channels),
         "RecordingDuration": float(exp.t[-1] - exp.t[0]) if len(exp.t) else 0.0,
         "RecordingType": "continuous", **counts}, f, indent=2))

    def events(f: Any) -> None:
        w = csv.writer(f, delimiter="\t", lineterminator="\n")
        w.writerow(["onset", "duration", "trial_type"])
        for when, label in exp.events:
            w.writerow([f"{when - exp.t[0]:.4f}", "0", f"{exp.side} {label}"])

    put(folder / f"{stem}_events.tsv", events)
    return written


def write_csv(exp: SessionExport, path: str | Path) -> Path:
    """Write the export as CSV, each column's unit in its header (``hip_flexion [deg]``).

    Parameters
    ----------
    exp : SessionExport
        What to write (:func:`session_export`).
    path : str or Path
        The CSV file.

    Returns
    -------
    Path
        The file written.
    """
    from exoleg.io import atomic_path

    head = ["t [s]"] + [f"{c.name} [{c.units}]" for c in exp.channels]
    data = np.stack([exp.t, *[c.values for c in exp.channels]], axis=1)
    with atomic_path(path) as tmp, tmp.open("w", encoding="utf-8") as f:
        f.write(",".join(head) + "\n")
        np.savetxt(f, data, delimiter=",", fmt="%.9g")
    return Path(path)
